"""Entry script of the PyInstaller bundle (packaging/robocal.spec): the `robocal` command.
With no arguments it opens the wizard, like the installed entry point."""
import sys

from app.cli import main

if __name__ == "__main__":
    sys.exit(main())
