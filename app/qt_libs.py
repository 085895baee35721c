"""The system libraries Qt needs, found before any window opens (no Qt is imported here).

Two ways to see what is missing, both on Linux with glibc:
- `ldd` on the PySide6 Qt libraries and the platform plugin (libqxcb.so for a desktop window,
  libqoffscreen.so for tests): what they link against and the loader cannot find;
- a probe: a child Python creates a QGuiApplication with `QT_DEBUG_PLUGINS=1` and reports the
  shared objects Qt itself says it cannot open ("libxcb-icccm.so.4: cannot open shared object
  file"). Qt's own last words are often a generic hint ("xcb-cursor0 … is needed") that names a
  library that is present while another is missing; the probe's lines name the real one.
Every missing shared object is mapped to its Debian package for one `apt-get install` line.
"""
from __future__ import annotations

import importlib.util
import os
import re
import shutil
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

from core.errors import RoboCalError

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

#: what Qt prints for a library the loader could not open (QT_DEBUG_PLUGINS output)
_CANNOT_OPEN = re.compile(r"(lib[\w.+-]+\.so(?:\.\d+)*): cannot open shared object file")
PROBE_SECONDS = 30
#: platforms that need a display server
DISPLAY_PLATFORMS = ("xcb", "wayland")


@dataclass
class QtLibraryCheck:
    """What keeps Qt's `platform` plugin from starting: missing shared objects (with their
    Debian packages), no display to open a window on, or a probe failure with Qt's own words."""

    platform: str
    missing: set[str] = field(default_factory=set)
    no_display: bool = False
    qt_says: str = ""              # Qt's last lines when the probe failed for a reason not named above

    @property
    def ok(self) -> bool:
        return not self.missing and not self.no_display and not self.qt_says

    @property
    def packages(self) -> list[str]:
        return sorted({p for p in map(package_for, self.missing) if p})

    def error(self) -> RoboCalError:
        """The one-line refusal `robocal gui` gives before any window is tried."""
        if self.missing:
            hint = ("Install them with: sudo apt-get install -y " + " ".join(self.packages)) if self.packages \
                else "Find the packages that hold them (apt-file search <name>)."
            return RoboCalError(f"Qt ({self.platform}) needs system libraries that are missing: "
                                f"{', '.join(sorted(self.missing))}", hint=hint)
        if self.no_display:
            return RoboCalError("no display found (DISPLAY is not set)",
                                hint="Run RoboCal on a desktop, or under Xvfb: xvfb-run robocal gui.")
        return RoboCalError(f"Qt could not start its '{self.platform}' platform plugin: "
                            + " / ".join(self.qt_says.splitlines()),
                            hint="Check the Qt installation (make demo checks it).")

    def message(self) -> str:
        """What to tell the user, in a few lines ("" when all is well)."""
        lines = []
        if self.missing:
            lines.append(f"Qt ({self.platform}) needs system libraries that are missing: "
                         f"{', '.join(sorted(self.missing))}.")
            if self.packages:
                lines.append("Install them with:\n  sudo apt-get install -y " + " ".join(self.packages))
            unknown = sorted(s for s in self.missing if package_for(s) is None)
            if unknown:
                lines.append(f"No known Debian package for: {', '.join(unknown)} (try `apt-file search <name>`).")
        elif self.qt_says:
            lines.append(f"Qt could not start its '{self.platform}' platform plugin. Qt says:\n{self.qt_says}")
        if self.no_display:
            lines.append("No display found (DISPLAY is not set). Run RoboCal on a desktop, or under Xvfb: "
                         "`sudo apt-get install -y xvfb` then `xvfb-run robocal gui`.")
        return "\n".join(lines)


def qt_dir() -> Path | None:
    """PySide6's Qt folder (lib/, plugins/), found without importing PySide6."""
    spec = importlib.util.find_spec("PySide6")
    if spec is None or not spec.submodule_search_locations:
        return None
    return Path(list(spec.submodule_search_locations)[0]) / "Qt"


def platform_in_use() -> str:
    """The platform plugin Qt will load: QT_QPA_PLATFORM's first choice, else xcb (or wayland
    on a Wayland-only session)."""
    chosen = os.environ.get("QT_QPA_PLATFORM", "").split(";")[0].split(":")[0].strip()
    if chosen:
        return chosen
    if os.environ.get("WAYLAND_DISPLAY") and not os.environ.get("DISPLAY"):
        return "wayland"
    return "xcb"


def package_for(soname: str) -> str | None:
    best = None
    for prefix, package in DEBIAN_PACKAGES.items():
        if soname.startswith(prefix) and (best is None or len(prefix) > len(best[0])):
            best = (prefix, package)
    return best[1] if best else None


def linked_missing(paths: list[Path]) -> set[str]:
    """The shared objects `ldd` reports as not found for these libraries."""
    missing: set[str] = set()
    for path in paths:
        if not path.exists():
            continue
        out = subprocess.run(["ldd", str(path)], capture_output=True, text=True).stdout
        for line in out.splitlines():
            if "=> not found" in line:
                missing.add(line.split("=>")[0].strip())
    return missing


def probe(platform: str) -> tuple[bool, set[str], str]:
    """Start a QGuiApplication on `platform` in a child Python with QT_DEBUG_PLUGINS=1:
    (started, the shared objects Qt could not open, Qt's last lines when it did not start)."""
    env = dict(os.environ, QT_QPA_PLATFORM=platform, QT_DEBUG_PLUGINS="1")
    code = "from PySide6.QtGui import QGuiApplication; QGuiApplication(['robocal-probe'])"
    try:
        run = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                             timeout=PROBE_SECONDS)
    except subprocess.TimeoutExpired:
        return False, set(), f"(no answer within {PROBE_SECONDS} s)"
    if run.returncode == 0:
        return True, set(), ""
    said = [ln for ln in run.stderr.splitlines() if ln.strip() and not ln.startswith("qt.core.")]
    return False, set(_CANNOT_OPEN.findall(run.stderr)), "\n".join(said[-3:])


def check_qt_libraries(platform: str | None = None, *, run_probe: bool = True) -> QtLibraryCheck:
    """Everything that keeps Qt's `platform` plugin (default: the one Qt will load) from starting.
    The probe runs only when ldd finds nothing and a display is there (it needs one)."""
    platform = platform or platform_in_use()
    result = QtLibraryCheck(platform)
    root = qt_dir()
    if shutil.which("ldd") is None or root is None:
        return result                      # not a glibc Linux, or a bundle that does not expose Qt's files
    libs = [root / "lib" / f"libQt6{m}.so.6" for m in ("Core", "Gui", "Widgets")]
    plugin = root / "plugins" / "platforms" / f"libq{platform}.so"
    result.missing = linked_missing(libs + [plugin])
    result.no_display = platform in DISPLAY_PLATFORMS and not (os.environ.get("DISPLAY")
                                                                or os.environ.get("WAYLAND_DISPLAY"))
    if run_probe and not result.missing and not result.no_display and not getattr(sys, "frozen", False):
        started, missing, said = probe(platform)
        if not started:
            result.missing = missing
            result.qt_says = "" if missing else said
    return result
