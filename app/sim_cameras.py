"""The virtual lab's two cameras watching the controller simulator's robot: after every motion
(`ControllerSim.on_rest`) the pair they see is written to two image folders, `DIR/left/frame.png`
and `DIR/right/frame.png` (each replaced atomically, before the controller says the move is done).

A project whose cameras are these two folders sees the simulated robot as a real cell's cameras
see a real one: a change made to the simulator's robot (`robocal sim-robot --change`) is in the
images and nowhere else. An image folder is read from its start again after its last image, so the
one frame of each folder is read anew at every capture.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from app.lab import VirtualLab
from core.files import atomic_write_bytes
from core.images import encode_png

FRAME = "frame.png"


class SimulatedCellCameras:
    """`on_rest(q_file)` renders `lab`'s true robot (as it is, changed or not) at joints `q_file`
    (deg / mm) and writes the pair under `folder`."""

    def __init__(self, lab: VirtualLab, folder: str | Path, *, seed: int = 0):
        self.lab = lab
        self.folder = Path(folder)
        self.rng = np.random.default_rng([int(seed), 43])
        self.frames = 0                     # pairs written

    @property
    def left(self) -> Path:
        return self.folder / "left"

    @property
    def right(self) -> Path:
        return self.folder / "right"

    def on_rest(self, q_file) -> None:
        q = self.lab.true_robot.q_from_file(np.asarray(q_file, dtype=float))
        pair = self.lab.render_marker_pair(q, self.rng)
        for side, image in zip((self.left, self.right), pair):
            atomic_write_bytes(side / FRAME, encode_png(image, "the simulated camera image", side / FRAME))
        self.frames += 1
