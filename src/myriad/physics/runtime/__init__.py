"""How the engine runs, apart from what it computes: devices (`devices`), compiling and loading
the kernels (`compile`), launching them on the CUDA stream or the CPU shards (`launch`), and the
CPU's float mode (`float_mode`)."""

from .compile import configure_modules, kernel_modules, load_kernels
from .devices import device_name, resolve_device
from .launch import Runtime

__all__ = ["Runtime", "configure_modules", "device_name", "kernel_modules", "load_kernels",
           "resolve_device"]
