"""A small document model: an ordered list of blocks, grouped into sections, rendered twice (HTML and
Markdown) so that the two files never disagree."""
from __future__ import annotations

import dataclasses
import math
from typing import Any, Iterable, Sequence

import numpy as np


@dataclasses.dataclass
class Block:
    kind: str  # p, list, table, fig, panel, code, math, kv
    text: str = ""
    items: list = dataclasses.field(default_factory=list)
    header: list = dataclasses.field(default_factory=list)
    rows: list = dataclasses.field(default_factory=list)
    path: str = ""  # figure path relative to DIR
    css: str = ""
    children: list = dataclasses.field(default_factory=list)
    mathml: str = ""
    number: int = 0  # figure number


@dataclasses.dataclass
class Section:
    key: str
    title: str
    blocks: list = dataclasses.field(default_factory=list)
    collapsed: bool = False  # rendered inside <details>
    css: str = ""

    @property
    def anchor(self) -> str:
        return self.key


class Doc:
    """Sections of blocks; :meth:`section` starts one, :meth:`panel` opens a boxed group (quoted / measured)."""

    def __init__(self):
        self.sections: list[Section] = []
        self._stack: list[list[Block]] = []
        self._figures = 0

    def section(self, key: str, title: str, *, collapsed: bool = False, css: str = "") -> Section:
        s = Section(key, title, collapsed=collapsed, css=css)
        self.sections.append(s)
        self._stack = [s.blocks]
        return s

    def _add(self, b: Block) -> None:
        self._stack[-1].append(b)

    def p(self, text: str, css: str = "") -> None:
        self._add(Block("p", text, css=css))

    def list(self, items: Iterable[str], css: str = "") -> None:
        self._add(Block("list", items=list(items), css=css))

    def table(self, header: Sequence[str], rows: Sequence[Sequence[Any]], css: str = "") -> None:
        self._add(Block("table", header=list(header), rows=[list(r) for r in rows], css=css))

    def fig(self, path: str, caption: str) -> int:
        self._figures += 1
        self._add(Block("fig", caption, path=path, number=self._figures))
        return self._figures

    def code(self, text: str) -> None:
        self._add(Block("code", text))

    def math(self, mathml: str, text: str, label: str = "") -> None:
        """An equation: MathML for the HTML, ``text`` (plain, Unicode) for the Markdown."""
        self._add(Block("math", text, mathml=mathml, css=label))

    def panel(self, title: str, css: str):
        doc = self

        class _Ctx:
            def __enter__(self_inner):
                b = Block("panel", title, css=css)
                doc._add(b)
                doc._stack.append(b.children)
                return b

            def __exit__(self_inner, *exc):
                doc._stack.pop()
                return False

        return _Ctx()

    @property
    def n_figures(self) -> int:
        return self._figures


def fmt(v: Any, digits: int = 4) -> str:
    """Numbers for tables: 4 significant digits, '-' for missing."""
    if v is None:
        return "-"
    if isinstance(v, (bool, np.bool_)):
        return "yes" if v else "no"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        if not math.isfinite(v):
            return "-"
        if v == 0:
            return "0"
        a = abs(v)
        if 1e-3 <= a < 1e5:
            return f"{v:.{digits}g}"
        return f"{v:.{max(digits - 1, 1)}e}"
    return str(v)


def pm(value: float | None, stderr: float | None, digits: int = 4) -> str:
    """'value ± stderr' (or just the value)."""
    if value is None:
        return "-"
    if stderr is None or not math.isfinite(stderr):
        return fmt(value, digits)
    return f"{fmt(value, digits)} ± {fmt(stderr, 2)}"
