"""A report page: headings, text, figures and tables written as HTML + PDF.

One page per experiment or archive. Figures are saved as PNG beside
``index.html``; the same content goes, in order, into ``report.pdf`` through
matplotlib's PdfPages, so the report needs nothing beyond matplotlib.

    page = ReportPage(title="ph-demo", out_dir=Path("reports/ph-demo"))
    page.heading("Detection")
    page.paragraph("Page-Hinkley detects ...")
    page.figure(fig, name="fig-6-4", caption="Figure 6.4 ...")
    page.table(rows, columns=["quantity", "thesis", "ours"], caption="...")
    page.write()
"""

from __future__ import annotations

import html
import textwrap
from dataclasses import dataclass, field
from pathlib import Path

import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.backends.backend_pdf import PdfPages  # noqa: E402

from contactlab.fileio import atomic_path, write_text_atomic  # noqa: E402

_CSS = """
body { font-family: -apple-system, 'Segoe UI', Helvetica, Arial, sans-serif; max-width: 62rem;
       margin: 2rem auto; padding: 0 1rem; color: #222; line-height: 1.45; }
h1 { border-bottom: 2px solid #444; padding-bottom: .2rem; }
figure { margin: 1.5rem 0; } figure img { max-width: 100%; border: 1px solid #ddd; }
figcaption, caption { font-size: .9rem; color: #444; text-align: left; padding: .3rem 0; }
table { border-collapse: collapse; margin: 1rem 0; font-size: .9rem; }
td, th { border: 1px solid #bbb; padding: .25rem .6rem; text-align: right; }
th { background: #f0f0f0; } td:first-child, th:first-child { text-align: left; }
p.note { background: #fff8e0; border-left: 4px solid #e0b000; padding: .4rem .8rem; }
"""


@dataclass
class _Block:
    kind: str  # heading | paragraph | note | figure | table
    text: str = ""
    level: int = 2
    name: str = ""
    figure: object = None
    rows: list = field(default_factory=list)
    columns: list = field(default_factory=list)


class ReportPage:
    """Collects blocks in order and writes ``index.html`` and ``report.pdf``."""

    def __init__(self, *, title: str, out_dir: str | Path):
        self.title = title
        self.out_dir = Path(out_dir)
        self.out_dir.mkdir(parents=True, exist_ok=True)
        self._blocks: list[_Block] = []

    def heading(self, text: str, *, level: int = 2) -> None:
        """A section heading (level 2 or 3)."""
        self._blocks.append(_Block("heading", text=text, level=level))

    def paragraph(self, text: str) -> None:
        """A paragraph of plain text."""
        self._blocks.append(_Block("paragraph", text=text))

    def note(self, text: str) -> None:
        """A highlighted paragraph: a choice made where the thesis is ambiguous,
        or a difference from the thesis and its explanation."""
        self._blocks.append(_Block("note", text=text))

    def figure(self, fig, *, name: str, caption: str) -> Path:
        """Save matplotlib ``fig`` as ``NAME.png`` and keep it for the PDF."""
        png = self.out_dir / f"{name}.png"
        with atomic_path(png, force=True) as tmp:
            fig.savefig(tmp, format="png", dpi=110, bbox_inches="tight")
        plt.close(fig)     # out of pyplot's registry; the object stays drawable for the PDF
        self._blocks.append(_Block("figure", text=caption, name=name, figure=fig))
        return png

    def table(self, rows, *, columns: list[str] | None = None, caption: str = "") -> None:
        """A table from a list of rows (with ``columns``) or a pandas DataFrame."""
        if hasattr(rows, "to_numpy") and hasattr(rows, "columns"):
            columns = [str(c) for c in rows.columns]
            rows = rows.to_numpy().tolist()
        rows = [[_fmt(v) for v in row] for row in rows]
        self._blocks.append(_Block("table", text=caption, rows=rows, columns=list(columns or [])))

    def write(self) -> dict[str, Path]:
        """Write ``index.html`` and ``report.pdf``; close the figures."""
        html_path = self.out_dir / "index.html"
        pdf_path = self.out_dir / "report.pdf"
        write_text_atomic(html_path, self._html())
        with atomic_path(pdf_path, force=True) as tmp:
            self._pdf(tmp)
        for b in self._blocks:
            if b.figure is not None:
                plt.close(b.figure)
        return {"html": html_path, "pdf": pdf_path}

    # -- rendering -----------------------------------------------------------------
    def _html(self) -> str:
        out = [f"<!doctype html><html><head><meta charset='utf-8'><title>{_e(self.title)}</title>",
               f"<style>{_CSS}</style></head><body><h1>{_e(self.title)}</h1>"]
        for b in self._blocks:
            if b.kind == "heading":
                out.append(f"<h{b.level}>{_e(b.text)}</h{b.level}>")
            elif b.kind == "paragraph":
                out.append(f"<p>{_e(b.text)}</p>")
            elif b.kind == "note":
                out.append(f"<p class='note'>{_e(b.text)}</p>")
            elif b.kind == "figure":
                out.append(f"<figure><img src='{_e(b.name)}.png' alt='{_e(b.name)}'>"
                           f"<figcaption>{_e(b.text)}</figcaption></figure>")
            elif b.kind == "table":
                head = "".join(f"<th>{_e(c)}</th>" for c in b.columns)
                body = "".join("<tr>" + "".join(f"<td>{_e(v)}</td>" for v in r) + "</tr>"
                               for r in b.rows)
                cap = f"<caption>{_e(b.text)}</caption>" if b.text else ""
                out.append(f"<table>{cap}<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>")
        out.append("</body></html>")
        return "\n".join(out)

    def _pdf(self, path: Path) -> None:
        with PdfPages(path, metadata={"CreationDate": None}) as pdf:  # reproducible bytes
            text: list[tuple[str, str]] = [("title", self.title)]
            for b in self._blocks:
                if b.kind in ("heading", "paragraph", "note"):
                    text.append((b.kind, b.text))
                    continue
                _text_page(pdf, text)
                text = []
                if b.kind == "figure":
                    b.figure.text(0.01, 0.005, textwrap.fill(b.text, 150), fontsize=7,
                                  va="bottom", ha="left")
                    pdf.savefig(b.figure)
                elif b.kind == "table":
                    _table_page(pdf, b)
            _text_page(pdf, text)


def _text_page(pdf: PdfPages, items: list[tuple[str, str]]) -> None:
    if not items:
        return
    lines: list[tuple[str, float, str]] = []  # (text, size, weight)
    for kind, text in items:
        if kind == "title":
            lines += [(text, 16, "bold"), ("", 10, "normal")]
        elif kind == "heading":
            lines += [("", 10, "normal"), (text, 12, "bold")]
        else:
            prefix = "Note: " if kind == "note" else ""
            lines += [(w, 9, "normal") for w in textwrap.wrap(prefix + text, 105)]
    per_page = 60
    for start in range(0, len(lines), per_page):
        fig = plt.figure(figsize=(8.27, 11.69))
        y = 0.95
        for text, size, weight in lines[start:start + per_page]:
            fig.text(0.07, y, text, fontsize=size, weight=weight, va="top", family="sans-serif")
            y -= 0.0145 * size / 9
        pdf.savefig(fig)
        plt.close(fig)


def _table_page(pdf: PdfPages, b: _Block) -> None:
    n = max(len(b.rows), 1)
    fig = plt.figure(figsize=(8.27, min(11.69, 1.5 + 0.28 * n)))
    ax = fig.add_axes([0.03, 0.03, 0.94, 0.85])
    ax.axis("off")
    if b.rows:
        t = ax.table(cellText=b.rows, colLabels=b.columns or None, loc="upper center", cellLoc="right")
        t.auto_set_font_size(False)
        t.set_fontsize(7)
        t.auto_set_column_width(list(range(len(b.rows[0]))))
    fig.text(0.03, 0.97, textwrap.fill(b.text, 120), fontsize=8, va="top")
    pdf.savefig(fig)
    plt.close(fig)


def _e(s) -> str:
    return html.escape(str(s), quote=True)


def _fmt(v) -> str:
    """Numbers to short strings for tables: 4 significant digits, ints as ints."""
    if isinstance(v, bool) or v is None:
        return "" if v is None else str(v)
    if isinstance(v, int):
        return str(v)
    try:
        f = float(v)
    except (TypeError, ValueError):
        return str(v)
    if f != f:
        return "—"
    if f == int(f) and abs(f) < 1e7:
        return str(int(f))
    return f"{f:.4g}"
