"""`python -m myriad.train task=Ant ...`: `myriad train` as a module, for launchers that start
Python modules; the way to train in several processes:

    torchrun --nproc_per_node=2 -m myriad.train task=Ant multi_gpu=true

starts two processes, each on its own GPU (cuda:LOCAL_RANK, NCCL) or, with device=cpu, on the
CPU (gloo), sharing num_envs between them. It takes the Hydra overrides of `myriad train`; see
myriad.rl.run and docs for the details and for several machines.
"""

from __future__ import annotations

import sys


def main(argv=None) -> int:
    from .cli import _hydra_command

    return _hydra_command("train", sys.argv[1:] if argv is None else list(argv))


if __name__ == "__main__":
    sys.exit(main())
