"""The work of the wizard's steps as plain Python (no Qt): what a page runs on a worker thread
with `TaskMixin.start`, one module per step, each testable with plain arguments."""
