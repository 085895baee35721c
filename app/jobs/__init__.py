"""The pages' long work as plain Python (no Qt): what a page runs on a worker thread through
`TaskMixin.start`, and the small file and list helpers behind its drawing, testable alone."""
