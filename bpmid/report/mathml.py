"""A few MathML helpers: equations in the page without scripts or external fonts (every current browser
renders MathML Core natively)."""
from __future__ import annotations

import html


def mi(x: str) -> str:
    return f"<mi>{html.escape(x)}</mi>"


def mn(x) -> str:
    return f"<mn>{html.escape(str(x))}</mn>"


def mo(x: str) -> str:
    return f"<mo>{html.escape(x)}</mo>"


def mtext(x: str) -> str:
    return f"<mtext>{html.escape(x)}</mtext>"


def row(*xs: str) -> str:
    return "<mrow>" + "".join(xs) + "</mrow>"


def sub(a: str, b: str) -> str:
    return f"<msub>{a}{b}</msub>"


def sup(a: str, b: str) -> str:
    return f"<msup>{a}{b}</msup>"


def subsup(a: str, b: str, c: str) -> str:
    return f"<msubsup>{a}{b}{c}</msubsup>"


def frac(a: str, b: str) -> str:
    return f"<mfrac>{a}{b}</mfrac>"


def under_over(op: str, lo: str, hi: str) -> str:
    return f"<munderover>{mo(op)}{lo}{hi}</munderover>"


def hat(x: str) -> str:
    return f'<mover accent="true">{x}{mo("^")}</mover>'


def bar(x: str) -> str:
    return f'<mover accent="true">{x}{mo("‾")}</mover>'


def paren(*xs: str) -> str:
    return row(mo("("), *xs, mo(")"))


def math(*xs: str) -> str:
    return '<math display="block">' + row(*xs) + "</math>"


def exp(arg: str) -> str:
    return sup(mi("e"), row(arg))
