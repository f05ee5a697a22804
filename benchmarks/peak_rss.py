"""Run one MPI rank's command as a child and record the child's peak resident set size from outside.

    mpirun -n 2 python3 benchmarks/peak_rss.py DIR -- python3 -m fenics_coulomb --lev 8 ...

Each rank's wrapper starts the command, waits for it and writes ``DIR/rss-<rank>.json`` with the peak RSS
that the kernel recorded for it (``getrusage(RUSAGE_CHILDREN).ru_maxrss``: the largest peak RSS among the
waited-for descendants, i.e. the rank's python3 process, whose JIT compiler children are far smaller).
The measurement needs nothing inside the measured process, misses no late peak (a poller of
``/proc/<pid>/status`` only sees VmHWM up to its last poll before the process exits) and works with any
launcher on any node (``mpirun``, ``srun``), because the wrapper runs where the rank runs. The wrapper's
exit status is the command's; SIGINT/SIGTERM are passed on to it. Standard library only.
"""

from __future__ import annotations

import json
import os
import resource
import signal
import socket
import subprocess
import sys
from pathlib import Path

#: Environment variables naming the rank, by launcher (Open MPI, PMIx, MPICH/Hydra, Slurm).
RANK_VARIABLES = ("OMPI_COMM_WORLD_RANK", "PMIX_RANK", "PMI_RANK", "SLURM_PROCID")


def rank_from_environment(env: dict[str, str] | os._Environ[str]) -> str:
    """The MPI rank as the launcher announces it, or ``pid<pid>`` when no launcher variable is set."""
    for key in RANK_VARIABLES:
        value = env.get(key, "")
        if value.isdigit():
            return value
    return f"pid{os.getpid()}"


def main(argv: list[str]) -> int:
    if len(argv) < 3 or argv[1] != "--":
        print("usage: peak_rss.py DIR -- COMMAND [ARGS...]", file=sys.stderr)
        return 2
    out, command = Path(argv[0]), argv[2:]
    out.mkdir(parents=True, exist_ok=True)
    child = subprocess.Popen(command)

    def forward(signum: int, _frame: object) -> None:
        child.send_signal(signum)

    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, forward)
    status = child.wait()
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    rank = rank_from_environment(os.environ)
    record = {"rank": rank, "host": socket.gethostname(), "pid": child.pid, "returncode": status,
              "peak_rss_kib": int(usage.ru_maxrss)}  # Linux reports kilobytes
    (out / f"rss-{rank}.json").write_text(json.dumps(record) + "\n")
    return status if status >= 0 else 128 - status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
