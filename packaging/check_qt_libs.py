"""Check that the system libraries Qt needs are present, without importing Qt.

Runs `ldd` on the PySide6 Qt libraries and on the platform plugin that will be used
(xcb for a desktop window, offscreen for tests) and maps every missing shared object to
its Debian package. Prints the exact `apt-get install` line and exits 1 if any is missing;
with --install (as root) installs them instead.
"""
from __future__ import annotations

import argparse
import importlib.util
import os
import shutil
import subprocess
import sys
from pathlib import Path

# soname prefix -> Debian package (bookworm / Ubuntu 22.04+ names)
DEBIAN_PACKAGES = {
    "libGL.so": "libgl1",
    "libEGL.so": "libegl1",
    "libOpenGL.so": "libopengl0",
    "libGLX.so": "libglx0",
    "libfontconfig.so": "libfontconfig1",
    "libfreetype.so": "libfreetype6",
    "libxkbcommon.so": "libxkbcommon0",
    "libxkbcommon-x11.so": "libxkbcommon-x11-0",
    "libglib-2.0.so": "libglib2.0-0",
    "libgthread-2.0.so": "libglib2.0-0",
    "libdbus-1.so": "libdbus-1-3",
    "libX11.so": "libx11-6",
    "libX11-xcb.so": "libx11-xcb1",
    "libxcb.so": "libxcb1",
    "libxcb-cursor.so": "libxcb-cursor0",
    "libxcb-icccm.so": "libxcb-icccm4",
    "libxcb-image.so": "libxcb-image0",
    "libxcb-keysyms.so": "libxcb-keysyms1",
    "libxcb-randr.so": "libxcb-randr0",
    "libxcb-render-util.so": "libxcb-render-util0",
    "libxcb-render.so": "libxcb-render0",
    "libxcb-shape.so": "libxcb-shape0",
    "libxcb-shm.so": "libxcb-shm0",
    "libxcb-sync.so": "libxcb-sync1",
    "libxcb-xfixes.so": "libxcb-xfixes0",
    "libxcb-xinerama.so": "libxcb-xinerama0",
    "libxcb-xkb.so": "libxcb-xkb1",
    "libxcb-util.so": "libxcb-util1",
    "libSM.so": "libsm6",
    "libICE.so": "libice6",
    "libXext.so": "libxext6",
    "libXrender.so": "libxrender1",
    "libXi.so": "libxi6",
    "libwayland-client.so": "libwayland-client0",
    "libwayland-cursor.so": "libwayland-cursor0",
    "libwayland-egl.so": "libwayland-egl1",
    "libzstd.so": "libzstd1",
    "libharfbuzz.so": "libharfbuzz0b",
    "libpng16.so": "libpng16-16",
    "libkrb5.so": "libkrb5-3",
    "libgssapi_krb5.so": "libgssapi-krb5-2",
}


def qt_dir() -> Path | None:
    spec = importlib.util.find_spec("PySide6")
    if spec is None or not spec.submodule_search_locations:
        return None
    return Path(list(spec.submodule_search_locations)[0]) / "Qt"


def missing_sonames(paths: list[Path]) -> set[str]:
    missing: set[str] = set()
    for path in paths:
        if not path.exists():
            continue
        out = subprocess.run(["ldd", str(path)], capture_output=True, text=True).stdout
        for line in out.splitlines():
            if "=> not found" in line:
                missing.add(line.split("=>")[0].strip())
    return missing


def package_for(soname: str) -> str | None:
    best = None
    for prefix, package in DEBIAN_PACKAGES.items():
        if soname.startswith(prefix) and (best is None or len(prefix) > len(best[0])):
            best = (prefix, package)
    return best[1] if best else None


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--platform", default="xcb", help="Qt platform plugin to check (xcb, offscreen, wayland)")
    parser.add_argument("--install", action="store_true", help="apt-get install what is missing (root only)")
    args = parser.parse_args(argv)

    if shutil.which("ldd") is None:
        return 0  # not a glibc Linux: nothing we can check this way
    root = qt_dir()
    if root is None:
        print("PySide6 is not installed in this environment: run `make test` or `make demo`, which install it.")
        return 1
    libs = [root / "lib" / f"libQt6{m}.so.6" for m in ("Core", "Gui", "Widgets")]
    plugin = root / "plugins" / "platforms" / f"libq{args.platform}.so"
    missing = missing_sonames(libs + [plugin])
    if not missing:
        if args.platform == "xcb" and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
            print("No display found (DISPLAY is not set). Run RoboCal on a desktop, or under Xvfb: "
                  "`sudo apt-get install -y xvfb` then `xvfb-run make demo`.")
            return 1
        return 0
    packages = sorted({package_for(s) or "" for s in missing} - {""})
    unknown = sorted(s for s in missing if package_for(s) is None)
    line = "sudo apt-get install -y " + " ".join(packages) if packages else ""
    if args.install and os.geteuid() == 0 and packages:
        subprocess.run(["apt-get", "update", "-q"], check=False)
        result = subprocess.run(["apt-get", "install", "-y", "-q", *packages], check=False)
        if result.returncode == 0 and not unknown:
            return 0
    print(f"Qt ({args.platform}) needs system libraries that are missing: {', '.join(sorted(missing))}.")
    if line:
        print(f"Install them with:\n  {line}")
    if unknown:
        print(f"No known Debian package for: {', '.join(unknown)} (try `apt-file search <name>`).")
    return 1


if __name__ == "__main__":
    sys.exit(main())
