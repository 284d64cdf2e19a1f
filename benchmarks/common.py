"""Shared helpers of the benchmark scripts: text tables, family selection."""


def format_table(header: list[str], rows: list[list[str]]) -> str:
    """Fixed-width text table: first column left-aligned, the others right-aligned."""
    widths = [max(len(row[k]) for row in [header, *rows]) for k in range(len(header))]
    lines = [
        "  ".join(cell.ljust(w) if k == 0 else cell.rjust(w) for k, (cell, w) in enumerate(zip(row, widths)))
        for row in [header, *rows]
    ]
    return "\n".join(lines)


def selected_families(parser, text: str, known, groups=None) -> list[str]:
    """The comma-separated family names in `text`, each group name (a key of `groups`)
    replaced by its families, in order, without repeats; a parser error naming unknown ones."""
    groups = groups or {}
    families = []
    for name in text.split(","):
        families += [f for f in groups.get(name, (name,)) if f not in families]
    unknown = sorted(set(families) - set(known))
    if unknown:
        parser.error(f"unknown families {unknown}; known: {', '.join([*groups, *known])}")
    return families
