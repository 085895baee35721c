"""The virtual lab: a simulated robot with known true geometry and two simulated cameras
that render realistic images (no Qt here).

    from core.virtual_lab.lab import VirtualLab              # the facade the app uses
    from core.virtual_lab.dataset import simulate_dataset    # `robocal simulate`

Modules: robot_errors (true robot), rig (stereo pair),
renderer (exact image synthesis), background (the room), lab, dataset.
"""
