"""Check that the system libraries Qt needs are present (app/qt_libs.py: `ldd` on Qt and its
platform plugin, then a probe that starts the plugin and reads which libraries Qt itself could
not open). Prints the exact `apt-get install` line and exits 1 if any is missing; with --install
(as root) installs them instead, checking again until nothing more is missing.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys

from app.qt_libs import check_qt_libraries

INSTALL_ROUNDS = 4          # the probe names one library a round: Qt stops at the first it cannot open


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--platform", default="xcb", help="Qt platform plugin to check (xcb, offscreen, wayland)")
    parser.add_argument("--install", action="store_true", help="apt-get install what is missing (root only)")
    args = parser.parse_args(argv)
    result = check_qt_libraries(args.platform)
    if args.install and os.geteuid() == 0:
        updated = False
        for _ in range(INSTALL_ROUNDS):
            if not result.packages:
                break
            if not updated:
                subprocess.run(["apt-get", "update", "-q"], check=False)
                updated = True
            if subprocess.run(["apt-get", "install", "-y", "-q", *result.packages], check=False).returncode != 0:
                break
            result = check_qt_libraries(args.platform)
    if result.ok:
        return 0
    print(result.message())
    return 1


if __name__ == "__main__":
    sys.exit(main())
