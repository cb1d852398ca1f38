"""Shared benchmark plumbing (DESIGN §9): machine/commit stamp, table, output/bench/NAME.json."""
import json
import os
import platform
import subprocess
from pathlib import Path

TOP = Path(__file__).resolve().parents[2]
SHARED_WORLDS = TOP.parent / "shared" / "worlds"    # real building maps (../shared/worlds/README.md)
REAL_MAPS = ("depot", "tb3_sandbox")                # the two of them, by name


def machine() -> str:
    model = platform.processor() or "unknown CPU"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{model}, {os.cpu_count()} cores"


def commit() -> str:
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=TOP, capture_output=True,
                              text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def write(name: str, figures: dict) -> Path:
    out = TOP / "output" / "bench" / f"{name}.json"
    out.parent.mkdir(parents=True, exist_ok=True)
    data = {**{k: (round(v, 4) if isinstance(v, float) else v) for k, v in figures.items()},
            "machine": machine(), "commit": commit()}
    out.write_text(json.dumps(data, indent=2, sort_keys=True) + "\n")
    width = max(len(k) for k in data)
    print(f"\n{name} benchmark")
    for k in sorted(data):
        print(f"  {k:<{width}}  {data[k]}")
    print(f"-> {out}")
    return out
