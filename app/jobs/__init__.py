"""The work the wizard's pages run on a worker thread: plain Python, no Qt, one module per step."""
