"""Device names: 'cpu', 'cuda' or 'cuda:N', checked once for the Simulator, the tasks and the CLI."""

from __future__ import annotations

import warp as wp


def device_name(device) -> str:
    """'cpu' or 'cuda:N' for 'cpu', 'cuda' (cuda:0) or 'cuda:N' (a str, torch or Warp device);
    any other name raises a one-line ValueError. Whether that GPU exists is not checked here."""
    name = str(device).strip()
    kind, colon, index = name.partition(":")
    if name == "cpu":
        return name
    if kind != "cuda" or colon and not (index.isascii() and index.isdigit()):
        raise ValueError(f"device {name!r}: expected 'cpu', 'cuda' or 'cuda:N'")
    return f"cuda:{int(index) if colon else 0}"


def resolve_device(device) -> wp.context.Device:
    """The Warp device of `device` (see `device_name`); a GPU that is not there raises a
    one-line ValueError."""
    name = device_name(device)
    try:
        return wp.get_device(name)
    except Exception:
        available = [str(d) for d in wp.get_devices()]
        raise ValueError(f"device {name!r} is not available (no such GPU); Warp sees "
                         f"{available}") from None
