#!/usr/bin/env python3
"""Scans whose every return lies within DISTANCE of the scanner, on every scanner of the scan
(FLASER and RLASER of one index in a CARMEN log): the laser sees nothing of the world beyond
what is right around the robot. In the simulated city that is a car driving through the robot
(llc simulate's cars keep their lane and speed: ranges down to 0.04 m on every beam), and its
scans say the robot stands while the wheels drive on; in the real logs, a robot in a tight spot. Prints, per log, how many such scans and
their runs of consecutive indices (the index llc slam gives the scan).

  scripts/lib/enclosed_scans.py [--distance 2.0] [--no-return 79.9] LOG [LOG ...]

LOG: a CARMEN log, plain or .gz (llc simulate's sim.log, ../shared/data/carmen/*.log.gz).
A range at or above --no-return, or not above 0, is no return and does not count.
"""
import argparse
import gzip
import signal
import sys

signal.signal(signal.SIGPIPE, signal.SIG_DFL)


def farthest_returns(path, no_return):
    """Per scanner tag, the farthest return of each scan in file order (0 when none)."""
    farthest = {"FLASER": [], "RLASER": []}
    opener = gzip.open if path.endswith(".gz") else open
    with opener(path, "rt", errors="replace") as log:
        for number, line in enumerate(log, 1):
            if not line.startswith(("FLASER", "RLASER")):
                continue
            fields = line.split()
            try:
                count = int(fields[1])
                ranges = [float(value) for value in fields[2:2 + count]]
            except (IndexError, ValueError):
                raise ValueError(f"{path}:{number}: not a laser line of a count and that many ranges")
            if len(ranges) != count:
                raise ValueError(f"{path}:{number}: {count} ranges announced, {len(ranges)} given")
            returns = [r for r in ranges if 0.0 < r < no_return]
            farthest[fields[0]].append(max(returns) if returns else 0.0)
    return farthest


def runs_of(indices):
    runs = []
    for k in indices:
        if runs and runs[-1][1] == k - 1:
            runs[-1][1] = k
        else:
            runs.append([k, k])
    return runs


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("logs", nargs="+", metavar="LOG")
    parser.add_argument("--distance", type=float, default=2.0, help="m; every return within this (default 2.0)")
    parser.add_argument("--no-return", type=float, default=79.9, help="m; ranges at or above are no return (default 79.9)")
    args = parser.parse_args()
    if not args.distance > 0.0 or not args.no_return > 0.0:
        parser.error("--distance and --no-return must be > 0")
    status = 0
    for path in args.logs:
        try:
            farthest = farthest_returns(path, args.no_return)
        except (OSError, ValueError, EOFError) as error:
            print(f"{path}: cannot read: {error}", file=sys.stderr)
            status = 1
            continue
        front, rear = farthest["FLASER"], farthest["RLASER"]
        enclosed = [k for k in range(len(front))
                    if 0.0 < front[k] < args.distance and (k >= len(rear) or 0.0 < rear[k] < args.distance)]
        runs = " ".join(f"{a}-{b}" if a != b else f"{a}" for a, b in runs_of(enclosed))
        print(f"{path}: scans={len(front)} enclosed={len(enclosed)} runs={runs or '-'}")
    return status


if __name__ == "__main__":
    sys.exit(main())
