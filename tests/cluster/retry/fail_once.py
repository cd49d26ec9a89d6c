"""Job of tests/cluster/retry/Snakefile: a partial output, then the work, then the rest.

``fail_once.py OUT --mem-mb M [--allocate-mb N] [--wait-at-mem-mb W]`` writes
``started mem_mb=M`` to OUT (what a job killed mid-way leaves), then touches every page of
N MiB (beyond M it waits to be killed: SLURM's cgroup or memory monitor kills the job) or,
when M == W, waits to be cancelled with scancel, and ends OUT with ``complete``.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

#: Seconds to wait for scancel (or the memory kill) before giving up: long enough that only
#: a hang reaches it on a loaded machine; the test then fails, never hangs for ever.
WAIT_FOR_CANCEL = 1800.0


def main(argv: list[str]) -> int:
    """Run the job; see the module docstring."""
    parser = argparse.ArgumentParser()
    parser.add_argument("output")
    parser.add_argument("--mem-mb", type=int, required=True)
    parser.add_argument("--allocate-mb", type=int, default=0)
    parser.add_argument("--wait-at-mem-mb", type=int, default=-1)
    args = parser.parse_args(argv)
    with open(args.output, "w") as fh:
        fh.write(f"started mem_mb={args.mem_mb}\n")
        fh.flush()
        os.fsync(fh.fileno())
        if args.allocate_mb:
            block = bytearray(args.allocate_mb * 2**20)
            block[::4096] = b"x" * len(block[::4096])  # touch every page: resident
            if args.allocate_mb > args.mem_mb:
                # over the limit: held until killed (at once by the cgroup, or at the next
                # sample of SLURM's memory monitor without cgroups, however late that is)
                time.sleep(WAIT_FOR_CANCEL)
                print(f"not killed within {WAIT_FOR_CANCEL} s over the limit",
                      file=sys.stderr)
                return 1
        if args.mem_mb == args.wait_at_mem_mb:
            time.sleep(WAIT_FOR_CANCEL)
            print(f"not cancelled within {WAIT_FOR_CANCEL} s", file=sys.stderr)
            return 1
        fh.write("complete\n")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
