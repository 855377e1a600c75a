"""Protocol fuzzing run: 1e6 datagrams against the decoders (Python, and the C plant's against it), 1e6
against each live real-time plant (Python and C), and a coverage-guided libFuzzer run of the C decoder.

Run:  python benchmarks/fuzz.py [--decoder 1000000] [--live 1000000] [--rate 20000] [--libfuzzer 60] [--json FILE]
The live runs take n / rate + a few seconds each (default ~55 s). The libFuzzer run needs clang with its
fuzzer runtime (Debian: apt-get install clang libclang-rt-14-dev); without it that part is reported as
skipped, with the reason. Results go to stdout (JSON) and the README.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from hydrohil.bench import emit, machine
from hydrohil.hil.fuzz import fuzz_c_decoder, fuzz_decoder, fuzz_live_plant, fuzz_stream

HERE = Path(__file__).resolve().parent


def libfuzzer(seconds: float, seed: int) -> dict:
    """Coverage-guided fuzzing of the C plant's decoder (fuzz_c_decoder.c) for ``seconds``, seeded with 200
    datagrams of the Python fuzzer. Returns executions, coverage and whether it found a crash."""
    import re
    import shutil
    import subprocess
    import tempfile
    from hydrohil.export.cplant import RT
    clang = shutil.which("clang") or next((shutil.which(f"clang-{v}") for v in range(20, 13, -1)
                                           if shutil.which(f"clang-{v}")), None)
    if clang is None:
        return {"skipped": "no clang (Debian: apt-get install clang libclang-rt-14-dev)"}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        exe = tmp / "fuzz_decoder"
        b = subprocess.run([clang, "-g", "-O1", "-fsanitize=fuzzer,address,undefined", "-I", str(RT),
                            str(HERE / "fuzz_c_decoder.c"), str(RT / "protocol.c"), "-o", str(exe)],
                           capture_output=True, text=True)
        if b.returncode != 0:
            return {"skipped": f"clang could not build the harness: {b.stderr.strip()[-300:]}"}
        corpus = tmp / "corpus"
        corpus.mkdir()
        for i, d in enumerate(fuzz_stream(200, seed)):
            (corpus / f"seed{i:03d}").write_bytes(d)
        r = subprocess.run([str(exe), f"-max_total_time={int(seconds)}", "-max_len=600", "-print_final_stats=1",
                            str(corpus)], capture_output=True, text=True, cwd=tmp)
        log = r.stderr
        stat = lambda name: int(m.group(1)) if (m := re.search(rf"{name}:\s+(\d+)", log)) else None  # noqa: E731
        cov = re.findall(r"cov: (\d+) ft: (\d+)", log)
        return {"seconds": seconds, "exit": r.returncode, "crash": r.returncode != 0,
                "executions": stat("stat::number_of_executed_units"), "execs_per_s": stat("stat::average_exec_per_sec"),
                "coverage_edges": int(cov[-1][0]) if cov else None, "features": int(cov[-1][1]) if cov else None,
                "corpus_final": len(list(corpus.iterdir())),
                "tail": log.strip().splitlines()[-3:] if r.returncode else []}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--decoder", type=int, default=1_000_000)
    ap.add_argument("--live", type=int, default=1_000_000)
    ap.add_argument("--rate", type=float, default=20_000.0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--libfuzzer", type=float, default=60.0, help="seconds of libFuzzer on the C decoder (0: none)")
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    res = {"machine": machine()}
    print(f"decoder: {args.decoder} datagrams ...", file=sys.stderr, flush=True)
    res["decoder"] = fuzz_decoder(args.decoder, args.seed)
    print(f"C decoder vs Python decoder: {args.decoder} datagrams ...", file=sys.stderr, flush=True)
    res["c_decoder"] = fuzz_c_decoder(args.decoder, args.seed)
    for plant in ("python", "c"):
        print(f"live {plant} plant: {args.live} datagrams at {args.rate:g}/s ...", file=sys.stderr, flush=True)
        live = fuzz_live_plant(args.live, args.rate, args.seed + 1, plant=plant)
        live["all_bad_counted"] = live["packets_bad"] == live["sent_malformed"]
        live["all_foreign_counted"] = live["packets_foreign"] == live["sent_well_formed"]
        live["all_accounted"] = (live["packets_bad"] + live["packets_foreign"] + live["packets_dropped_kernel"]
                                 >= live["sent_malformed"] + live["sent_well_formed"])
        res["live_plant" if plant == "python" else "live_c_plant"] = live
    if args.libfuzzer > 0:
        print(f"libFuzzer on the C decoder: {args.libfuzzer:g} s ...", file=sys.stderr, flush=True)
        res["libfuzzer"] = libfuzzer(args.libfuzzer, args.seed)
    emit(res, args.json)


if __name__ == "__main__":
    main()
