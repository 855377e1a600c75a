"""Protocol fuzzing run (issue #6): 1e6 datagrams against the decoder, 1e6 against a live real-time plant.

Run:  python benchmarks/fuzz.py [--decoder 1000000] [--live 1000000] [--rate 20000] [--json FILE]
The live run takes n / rate + a few seconds (default ~55 s). Results go to stdout (JSON) and the README.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from hydrohil.bench import emit, machine
from hydrohil.hil.fuzz import fuzz_decoder, fuzz_live_plant


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--decoder", type=int, default=1_000_000)
    ap.add_argument("--live", type=int, default=1_000_000)
    ap.add_argument("--rate", type=float, default=20_000.0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    res = {"machine": machine()}
    print(f"decoder: {args.decoder} datagrams ...", file=sys.stderr, flush=True)
    res["decoder"] = fuzz_decoder(args.decoder, args.seed)
    print(f"live plant: {args.live} datagrams at {args.rate:g}/s ...", file=sys.stderr, flush=True)
    live = fuzz_live_plant(args.live, args.rate, args.seed + 1)
    live["all_bad_counted"] = live["packets_bad"] == live["sent_malformed"]
    live["all_foreign_counted"] = live["packets_foreign"] == live["sent_well_formed"]
    live["all_accounted"] = (live["packets_bad"] + live["packets_foreign"] + live["packets_dropped_kernel"]
                             >= live["sent_malformed"] + live["sent_well_formed"])
    res["live_plant"] = live
    emit(res, args.json)


if __name__ == "__main__":
    main()
