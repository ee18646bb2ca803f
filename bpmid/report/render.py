"""Rendering a :class:`~bpmid.report.doc.Doc`: one self-contained HTML file (inline CSS, figures embedded:
PNG as base64, SVG inlined, no scripts, no external links or fonts) and a Markdown twin whose figures are
files next to it."""
from __future__ import annotations

import base64
import html
import re
from importlib import resources
from pathlib import Path

from bpmid import __version__
from bpmid.report.doc import Block, Doc

_NUM = re.compile(r"^[-+−]?(?:\d[\d,]*\.?\d*(?:e[-+]?\d+)?|\.\d+)(?:\s*±\s*[\d.e+-]+)?\s*%?$", re.I)
_HASH = re.compile(r"^[0-9a-f]{40,64}$")


def css() -> str:
    return resources.files("bpmid.report").joinpath("report.css").read_text(encoding="utf-8")


def _md_cell(v) -> str:
    return str(v).replace("|", "\\|").replace("\n", " ")


def render_markdown(doc: Doc, title: str) -> str:
    out = [f"# {title}", ""]

    def emit(blocks, quote=False):
        pre = "> " if quote else ""
        for b in blocks:
            if b.kind == "p":
                out.extend([pre + b.text, pre])
            elif b.kind == "list":
                out.extend([pre + f"- {it}" for it in b.items] + [pre])
            elif b.kind == "code":
                out.extend([pre + "```"] + [pre + ln for ln in b.text.splitlines()] + [pre + "```", pre])
            elif b.kind == "math":
                out.extend([pre + "    " + b.text + (f"    ({b.css})" if b.css else ""), pre])
            elif b.kind == "table":
                out.append(pre + "| " + " | ".join(_md_cell(h) for h in b.header) + " |")
                out.append(pre + "|" + "|".join("---" for _ in b.header) + "|")
                for r in b.rows:
                    out.append(pre + "| " + " | ".join(_md_cell(c) for c in r) + " |")
                out.append(pre)
            elif b.kind == "fig":
                out.extend([pre + f"![Figure {b.number}]({b.path})", pre, pre + f"*Figure {b.number}. {b.text}*", pre])
            elif b.kind == "panel":
                out.extend([f"**{b.text}**", ""])
                emit(b.children, quote=True)
                out.append("")

    for s in doc.sections:
        out.extend([f"## {s.title}", ""])
        emit(s.blocks)
    return "\n".join(out).rstrip() + "\n"


def inline_svg(text: str, prefix: str) -> str:
    """An SVG file as an element of the page: XML prolog and DOCTYPE dropped, every id made unique to this
    figure (several figures in one page share matplotlib's ids), fixed size replaced by a responsive one."""
    text = re.sub(r"^\s*<\?xml[^>]*>\s*", "", text)
    text = re.sub(r"<!DOCTYPE[^>]*>\s*", "", text, flags=re.S)
    text = re.sub(r"<metadata>.*?</metadata>", "", text, flags=re.S)
    ids = set(re.findall(r'\bid="([^"]+)"', text))
    if ids:
        pat = re.compile(r'(\bid="|url\(#|href="#)(' + "|".join(re.escape(i) for i in sorted(ids, key=len,
                                                                                             reverse=True)) + r')\b')
        text = pat.sub(lambda m: f"{m.group(1)}{prefix}-{m.group(2)}", text)
    m = re.search(r"<svg\b[^>]*>", text)
    if m:
        tag = m.group(0)
        w = re.search(r'\bwidth="([\d.]+)pt"', tag)
        new = re.sub(r'\s(width|height)="[^"]*"', "", tag)
        style = f' style="max-width:{w.group(1)}pt"' if w else ""
        new = new[:-1] + f' role="img"{style}>'
        text = text.replace(tag, new, 1)
    return text.strip()


def _cell(v, text: bool = False) -> str:
    s = str(v)
    cls = ""
    if text:
        pass
    elif _HASH.match(s):
        cls = ' class="hash"'
    elif s.startswith("/") or (("/" in s or "\\" in s) and " " not in s):
        cls = ' class="path"'
    elif _NUM.match(s.replace(" ", "")):
        cls = ' class="num"'
    return f"<td{cls}>{html.escape(s)}</td>"


def render_html(doc: Doc, title: str, base: Path) -> str:
    """Self-contained HTML: every figure read from ``base / path`` and embedded."""
    esc = html.escape
    out = ["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
           '<meta name="viewport" content="width=device-width, initial-scale=1">',
           f"<title>{esc(title)}</title>", f"<style>{css()}</style></head><body>", f"<h1>{esc(title)}</h1>"]

    def figure(b: Block) -> str:
        path = base / b.path
        cap = f"<figcaption><b>Figure {b.number}.</b> {esc(b.text)}</figcaption>"
        if path.suffix.lower() == ".svg":
            body = inline_svg(path.read_text(encoding="utf-8"), f"f{b.number}")
            return f'<figure id="fig{b.number}" aria-label="Figure {b.number}">{body}{cap}</figure>'
        if path.suffix.lower() == ".pdf":  # browsers cannot show a PDF in a page: its PNG twin, if any
            if not path.with_suffix(".png").is_file():
                return (f'<figure id="fig{b.number}"><p class="verdict">Figure {b.number} is a vector PDF: '
                        f"{esc(b.path)} (next to this report; PDF figures cannot be embedded in a page).</p>{cap}"
                        "</figure>")
            path = path.with_suffix(".png")
        data = base64.b64encode(path.read_bytes()).decode("ascii")
        return (f'<figure id="fig{b.number}"><img alt="Figure {b.number}: {esc(b.text)}" '
                f'src="data:image/png;base64,{data}">{cap}</figure>')

    def emit(blocks):
        i = 0
        while i < len(blocks):
            b = blocks[i]
            if b.kind == "panel":
                group = []
                while i < len(blocks) and blocks[i].kind == "panel":
                    group.append(blocks[i])
                    i += 1
                out.append('<div class="panels">')
                for g in group:
                    badge = "QUOTED" if "quoted" in g.css else "MEASURED HERE"
                    out.append(f'<section class="panel {esc(g.css)}"><h3><span class="badge">{badge}</span>'
                               f"{esc(g.text)}</h3>")
                    emit(g.children)
                    out.append("</section>")
                out.append("</div>")
                continue
            if b.kind == "p":
                cls = f' class="{esc(b.css)}"' if b.css else ""
                out.append(f"<p{cls}>{esc(b.text)}</p>")
            elif b.kind == "list":
                cls = f' class="{esc(b.css)}"' if b.css else ""
                out.append(f"<ul{cls}>" + "".join(f"<li>{esc(str(it))}</li>" for it in b.items) + "</ul>")
            elif b.kind == "code":
                out.append(f"<pre>{esc(b.text)}</pre>")
            elif b.kind == "math":
                lab = f'<span class="eqlabel">({esc(b.css)})</span>' if b.css else ""
                out.append(f'<div class="eq">{b.mathml}{lab}</div>')
            elif b.kind == "table":
                cls = f' class="{esc(b.css)}"' if b.css else ""
                out.append(f'<div class="tablewrap"><table{cls}><thead><tr>'
                           + "".join(f"<th>{esc(str(h))}</th>" for h in b.header) + "</tr></thead><tbody>")
                text_cols = {i for i, h in enumerate(b.header) if str(h) in ("unit", "model", "controller")}
                for r in b.rows:
                    out.append("<tr>" + "".join(_cell(c, i in text_cols) for i, c in enumerate(r)) + "</tr>")
                out.append("</tbody></table></div>")
            elif b.kind == "fig":
                out.append(figure(b))
            i += 1

    body_sections = [s for s in doc.sections if not s.collapsed and s.key != "summary"]
    for s in doc.sections:
        if s.key == "summary":
            out.append(f'<section id="{esc(s.anchor)}" class="summary"><h2>{esc(s.title)}</h2>')
            emit(s.blocks)
            out.append("</section>")
            if body_sections:
                out.append("<nav><ul>" + "".join(f'<li><a href="#{esc(b.anchor)}">{esc(b.title)}</a></li>'
                                                 for b in body_sections) + "</ul></nav>")
        elif s.collapsed:
            out.append(f'<section id="{esc(s.anchor)}" class="{esc(s.css)}"><details><summary>{esc(s.title)}'
                       "</summary>")
            emit(s.blocks)
            out.append("</details></section>")
        else:
            out.append(f'<section id="{esc(s.anchor)}" class="{esc(s.css)}"><h2>{esc(s.title)}</h2>')
            emit(s.blocks)
            out.append("</section>")
    out.append(f'<p class="muted">Written by bpmid {esc(__version__)} (bpmid report).</p></body></html>')
    return "\n".join(out) + "\n"
