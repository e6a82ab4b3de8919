"""The report page builder writes a complete HTML page and a readable PDF."""

from __future__ import annotations

import matplotlib.pyplot as plt

from contactlab.report.page import ReportPage


def test_page_writes_html_with_every_block_and_a_pdf(tmp_path):
    page = ReportPage(title="T <&>", out_dir=tmp_path)
    page.heading("Section")
    page.paragraph("x < y & z")
    page.note("a choice")
    fig, ax = plt.subplots()
    ax.plot([0, 1], [1, 0])
    page.figure(fig, name="fig-1", caption="the caption")
    page.table([["a", 1.234567, 3], ["b", float("nan"), 10]], columns=["k", "v", "n"],
               caption="tab")
    paths = page.write()
    html = paths["html"].read_text()
    assert "T &lt;&amp;&gt;" in html and "x &lt; y &amp; z" in html
    assert "<img src='fig-1.png'" in html and (tmp_path / "fig-1.png").stat().st_size > 1000
    assert "<td>1.235</td>" in html and "<td>—</td>" in html
    pdf = paths["pdf"].read_bytes()
    assert pdf.startswith(b"%PDF") and pdf.count(b"/Type /Page\n") + pdf.count(b"/Type /Page ") >= 1
    # no temporary files left behind by the atomic writes
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]
