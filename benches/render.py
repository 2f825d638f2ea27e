#!/usr/bin/env python3
"""Renders the tables of README.md and docs/*.md from benches/results/*.json.

A table to render sits between two markers:

    <!-- table contact result.resting_ball radius_m:ball radius m | drift_mm:moved in 2 s, mm:.3f -->
    ...rendered table...
    <!-- end table -->

After `table`: the results file (benches/results/NAME.json), the path to a list of rows in it
(dot-separated keys; or several objects, comma-separated, one row each; then optional
`?key=value` filters on the rows), then the columns separated by ` | `, each `key:header` or
`key:header:format` (a Python format spec; no colon in the header), or
`key:header:format:scale` (the value times scale, e.g. 100 for a figure quoted x 100). Everything between the
markers is replaced; a line under the table names the file, its command, commit and date, so
every rendered figure says where it came from.

Usage: benches/render.py [--check]   (--check: exit 1 if any page would change)
"""
import json
import pathlib
import re
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
# A marker is a line of its own; the text may mention `<!-- table -->` in passing.
MARKER = re.compile(r"^<!-- table (\S+) (\S+) ([^\n]*?) -->\n.*?^<!-- end table -->$", re.S | re.M)


def lookup(record, path):
    """The rows at `path`: dot-separated keys to a list of rows, or comma-separated paths to
    objects (one row each, its last key under `_path`), then optional `?key=value` filters."""
    path, *filters = path.split("?")
    rows = []
    for part in path.split(","):
        value = record
        for key in part.split("."):
            value = value[int(key)] if isinstance(value, list) else value[key]
        if isinstance(value, dict):
            rows.append({**value, "_path": part.split(".")[-1]})
        else:
            rows.extend(value)
    for condition in filters:
        key, wanted = condition.split("=")
        rows = [row for row in rows if str(row.get(key)) == wanted]
    return rows


def field(row, key):
    """row[key], following dots into nested objects (case.name)."""
    for part in key.split("."):
        row = row.get(part) if isinstance(row, dict) else None
    return row


def cell(value, fmt):
    if value is None:
        return "-"
    if fmt and isinstance(value, (int, float)) and not isinstance(value, bool):
        return format(value, fmt)
    return str(value)


def render(match):
    name, path, spec = match.group(1), match.group(2), match.group(3)
    record = json.loads((ROOT / "benches" / "results" / f"{name}.json").read_text())
    columns = []
    for column in spec.split(" | "):
        key, header, *rest = column.split(":")
        fmt = rest[0] if rest else ""
        scale = float(rest[1]) if len(rest) > 1 else None
        columns.append((key, header, fmt, scale))
    rows = lookup(record, path)
    lines = [
        "| " + " | ".join(header for _, header, _, _ in columns) + " |",
        "|" + "|".join("---:" if fmt else "---" for _, _, fmt, _ in columns) + "|",
    ]
    for row in rows:
        cells = []
        for key, _, fmt, scale in columns:
            value = field(row, key)
            if scale is not None and isinstance(value, (int, float)):
                value = value * scale
            cells.append(cell(value, fmt))
        lines.append("| " + " | ".join(cells) + " |")
    source = (
        f"\n`benches/results/{name}.json`: `{record.get('command', '?')}`, "
        f"commit {record.get('commit', '?')}, {record.get('date', '?')}."
    )
    return match.group(0).split("\n", 1)[0] + "\n" + "\n".join(lines) + "\n" + source + "\n<!-- end table -->"


def main():
    check = "--check" in sys.argv
    stale = []
    for page in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        text = page.read_text()
        new = MARKER.sub(render, text)
        if new != text:
            stale.append(page.relative_to(ROOT))
            if not check:
                page.write_text(new)
    for page in stale:
        print(f"{'stale' if check else 'rendered'}: {page}")
    return 1 if check and stale else 0


if __name__ == "__main__":
    sys.exit(main())
