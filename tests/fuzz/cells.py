"""One cell of a delimited text file replaced, for the fuzz tests of every CSV-like input."""
from __future__ import annotations


def with_cell(text: str, line: int, column: int, value: str, sep: str = ",") -> str:
    """`text` with the cell at (`line`, `column`) replaced by `value` (indices beyond the last
    line or cell name the last one), ending in a newline."""
    lines = text.splitlines()
    line = min(line, len(lines) - 1)
    cells = lines[line].split(sep)
    cells[min(column, len(cells) - 1)] = value
    lines[line] = sep.join(cells)
    return "\n".join(lines) + "\n"
