"""The virtual lab's room: made once per seed and rig, never changed, drawn once per rig."""
from __future__ import annotations

import copy

import numpy as np
import pytest

from core.camera import CameraModel
from core.stereo.rig import StereoRig
from core.virtual_lab.background import make_room
from core.virtual_lab.lab import VirtualLab
from core.virtual_lab.renderer import ImageComposer
from core.virtual_lab.rig import right_from_left


def drawn_by_hand(room, rig) -> tuple[np.ndarray, np.ndarray]:
    left, right = ImageComposer(rig.left, None), ImageComposer(rig.right, right_from_left(rig))
    room.draw(left)
    room.draw(right)
    return left.canvas, right.canvas


def test_labs_of_one_seed_share_a_room_that_cannot_be_changed():
    a, b, other = VirtualLab.create(seed=5), VirtualLab.create(seed=5), VirtualLab.create(seed=6)
    assert a.room is b.room and other.room is not a.room
    assert not np.array_equal(other.room.wall.texture[:200, :200], a.room.wall.texture[:200, :200])
    assert copy.deepcopy(a).room is a.room
    for texture in (a.room.wall.texture, a.room.table.texture):
        with pytest.raises(ValueError, match="read-only"):
            texture[0, 0] = 0


def test_the_shared_room_is_the_room_the_seed_makes():
    lab = VirtualLab.create(seed=5)
    streams = np.random.SeedSequence(5).spawn(5)
    made = make_room(np.random.default_rng(streams[3]), lab.rig, wall_depth=lab.room.wall.world_from_plane[2, 3],
                     table_height=lab.room.table.world_from_plane[1, 3])
    assert np.array_equal(made.wall.texture, lab.room.wall.texture)
    assert np.array_equal(made.table.texture, lab.room.table.texture)


def test_the_room_is_drawn_for_each_rig_as_its_cameras_see_it():
    lab = VirtualLab.create(seed=5)
    rig = lab.rig
    seen = lab.room.canvases(rig)
    assert all(np.array_equal(c, d) for c, d in zip(seen, drawn_by_hand(lab.room, rig)))
    assert lab.room.canvases(copy.deepcopy(rig))[0] is seen[0]           # an equal rig: drawn once
    wider = [-0.28, 0.12, 0.0005, -0.0003, 0.01]
    other = StereoRig(CameraModel(rig.left.K, wider, *rig.left.size), CameraModel(rig.right.K, wider, *rig.right.size),
                      rig.R, rig.T)
    changed = lab.room.canvases(other)
    assert not np.array_equal(changed[0], seen[0])
    assert all(np.array_equal(c, d) for c, d in zip(changed, drawn_by_hand(lab.room, other)))
