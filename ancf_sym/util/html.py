"""The small HTML tables the results show in notebooks (Jupyter calls _repr_html_)."""
from __future__ import annotations


def html_table(kind: str, title: str, rows: list) -> str:
    """A small HTML table for notebooks (Jupyter calls _repr_html_)."""
    import html
    body = "".join(f"<tr><th style='text-align:left'>{html.escape(str(k))}</th><td style='text-align:left'>"
                   f"{html.escape(str(v))}</td></tr>" for k, v in rows)
    return f"<div><b>{html.escape(kind)}</b>: {html.escape(title)}<table>{body}</table></div>"
