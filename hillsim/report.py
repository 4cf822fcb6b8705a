"""A single self-contained HTML report (figures embedded as base64 PNG, tables of key numbers).

Every number that comes from a result file is written with its exact value in a ``data-value`` attribute and its
source in ``data-key`` (``file.json:key``), so a test can check that the report says what the JSON files say.
"""

from __future__ import annotations

import base64
import html
import math
from dataclasses import dataclass, field
from pathlib import Path


@dataclass(frozen=True)
class Value:
    """A number in a report table: exact value, display format, and the JSON key it comes from."""

    value: float
    fmt: str = "{:.4g}"
    key: str | None = None

    def cell(self) -> str:
        text = "n/a" if self.value is None or (isinstance(self.value, float) and math.isnan(self.value)) else (
            self.fmt.format(self.value)
        )
        attrs = f' data-value="{html.escape(repr(self.value))}"'
        if self.key:
            attrs += f' data-key="{html.escape(self.key)}"'
        return f"<td class='num'{attrs}>{html.escape(text)}</td>"


def _cell(item) -> str:
    if isinstance(item, Value):
        return item.cell()
    return f"<td>{html.escape(str(item))}</td>"


@dataclass
class Report:
    """Collects sections, tables and figures; :meth:`write` makes one HTML file with everything inside."""

    title: str
    parts: list[str] = field(default_factory=list)

    def heading(self, text: str) -> None:
        self.parts.append(f"<h2>{html.escape(text)}</h2>")

    def paragraph(self, text: str) -> None:
        self.parts.append(f"<p>{html.escape(text)}</p>")

    def table(self, headers, rows, caption: str | None = None) -> None:
        head = "".join(f"<th>{html.escape(str(h))}</th>" for h in headers)
        body = "".join("<tr>" + "".join(_cell(c) for c in row) + "</tr>" for row in rows)
        cap = f"<caption>{html.escape(caption)}</caption>" if caption else ""
        self.parts.append(f"<table>{cap}<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>")

    def figure(self, png: Path, caption: str) -> None:
        data = base64.b64encode(Path(png).read_bytes()).decode("ascii")
        self.parts.append(
            f"<figure><img alt='{html.escape(caption)}' src='data:image/png;base64,{data}'>"
            f"<figcaption>{html.escape(caption)} <span class='file'>({html.escape(Path(png).name)})</span>"
            "</figcaption></figure>"
        )

    def to_html(self) -> str:
        style = (
            "body{font-family:system-ui,sans-serif;max-width:1100px;margin:2em auto;color:#222;line-height:1.4}"
            "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #bbb;padding:3px 8px}"
            "th{background:#eef}td.num{text-align:right;font-variant-numeric:tabular-nums}"
            "caption{font-weight:600;text-align:left;padding:4px 0}figure{margin:1em 0}"
            "img{max-width:100%;border:1px solid #ddd}figcaption{font-size:90%;color:#555}.file{color:#999}"
        )
        return (
            "<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
            f"<title>{html.escape(self.title)}</title><style>{style}</style></head><body>"
            f"<h1>{html.escape(self.title)}</h1>" + "\n".join(self.parts) + "</body></html>\n"
        )

    def write(self, path) -> Path:
        path = Path(path)
        path.write_text(self.to_html(), encoding="utf-8")
        return path
