"""The pages' long work, plain Python (no Qt) run on a worker thread: one module per step."""
