"""Run the desktop bundle as a user would: `make package-check`.

From a temporary folder, with no virtual environment on PATH and no PYTHONPATH: `robocal
--help`, `robocal simulate` into the temporary folder, and `robocal gui --demo --autopilot
--screenshots` offscreen. Prints the bundle's size and its start-up time (`--help`, best of
three, s); exits 1 with the failing step's output when one fails.
"""
from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def folder_size(folder: Path) -> int:
    return sum(p.stat().st_size for p in folder.rglob("*") if p.is_file() and not p.is_symlink())


def clean_env(tmp: Path) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV", "PYTHONHOME")}
    env["PATH"] = os.pathsep.join(p for p in env.get("PATH", "").split(os.pathsep)
                                  if p and ".venv" not in p and "/venv" not in p)
    env["HOME"] = str(tmp / "home")              # nothing touches the user's settings
    env["QT_QPA_PLATFORM"] = "offscreen"
    (tmp / "home").mkdir()
    return env


def run(step: str, argv: list[str], env: dict, cwd: Path, timeout: float) -> float:
    t0 = time.perf_counter()
    done = subprocess.run(argv, env=env, cwd=cwd, capture_output=True, text=True, timeout=timeout)
    elapsed = time.perf_counter() - t0
    if done.returncode != 0:
        print(f"FAILED: {step} (exit {done.returncode})\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}")
        raise SystemExit(1)
    print(f"ok   {step} ({elapsed:.1f} s)")
    return elapsed


def main(argv: list[str]) -> int:
    bundle = Path(argv[1] if len(argv) > 1 else "dist/robocal").resolve()
    exe = bundle / "robocal"
    if not exe.is_file():
        print(f"No bundle at {bundle}: run `make package` first.")
        return 1
    with tempfile.TemporaryDirectory(prefix="robocal-bundle-") as tmp:
        tmp = Path(tmp)
        env = clean_env(tmp)
        starts = [run("robocal --help", [str(exe), "--help"], env, tmp, 120) for _ in range(3)]
        run("robocal simulate", [str(exe), "simulate", "--out", str(tmp / "sim")], env, tmp, 600)
        if not any((tmp / "sim").iterdir()):
            print("FAILED: robocal simulate wrote nothing")
            return 1
        shots = tmp / "shots"
        run("robocal gui --demo --autopilot --screenshots (offscreen)",
            [str(exe), "gui", "--demo", "--autopilot", "--screenshots", str(shots)], env, tmp, 1200)
        pngs = sorted(shots.glob("*.png"))
        if len(pngs) < 7:
            print(f"FAILED: {len(pngs)} screenshots, expected one per page (7)")
            return 1
        print(f"ok   {len(pngs)} screenshots: {', '.join(p.name for p in pngs)}")
    print(f"bundle size: {folder_size(bundle) / 1e6:.0f} MB ({bundle})")
    print(f"start-up time (robocal --help, best of 3): {min(starts):.2f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
