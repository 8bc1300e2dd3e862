"""The doc checks of tests/test_docs.py for tables and blocks: ```python blocks, the protocol's
command table, the config table in docs/firmware.md."""

import ast
import re

def check_python_block(doc, source, index):
    """A ```python block: it parses, its imports resolve, its calls match the signatures."""
    problems = []
    try:
        tree = ast.parse(source)
    except SyntaxError as e:
        return ["%s: python block does not parse: %s" % (doc, e)]
    types = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            for a in node.names:
                problem = index.resolve(node.module + "." + a.name)
                if problem:
                    problems.append("%s: %s" % (doc, problem))
        elif isinstance(node, ast.Assign) and isinstance(node.value, ast.Call) and \
                isinstance(node.value.func, ast.Name) and node.value.func.id in index.classes:
            for t in node.targets:
                if isinstance(t, ast.Name):
                    types[t.id] = node.value.func.id
    for node in ast.walk(tree):
        if not isinstance(node, ast.Call):
            continue
        f = node.func
        keywords = [k.arg for k in node.keywords if k.arg]
        if isinstance(f, ast.Name):
            name = "__init__" if f.id in index.classes else f.id
        elif isinstance(f, ast.Attribute):
            owner = f.value.id if isinstance(f.value, ast.Name) else None
            cls = types.get(owner, owner)
            has = index.class_has(cls, f.attr) if cls else None
            if has is False or (has is None and f.attr not in index.words):
                problems.append("%s: %s has no %s" % (doc, cls, f.attr))
                continue
            name = f.attr
        else:
            continue
        problem = index.accepts(name, len(node.args), keywords,
                                cls if isinstance(f, ast.Attribute) and cls in index.classes else
                                (f.id if isinstance(f, ast.Name) and f.id in index.classes else None))
        if problem:
            problems.append("%s: %s" % (doc, problem))
    return problems


def command_table():
    from desktop.firmware.files import import_device
    return dict(import_device("commands").TABLE)


def config_schema():
    from desktop.firmware.files import import_device
    return dict(import_device("config").SCHEMA)


def check_protocol_doc(doc, prose, code, table):
    """docs/protocol.md: its command table lists exactly TABLE; its example requests exist."""
    problems = []
    listed, in_table = set(), False
    for _n, line in prose:
        if line.startswith("| command |"):
            in_table = True
        elif not line.startswith("|"):
            in_table = False
        m = re.match(r"^\| `([a-z][\w-]*)", line)
        if m and in_table:
            listed.add(m.group(1))
    if doc == "docs/protocol.md":
        for cmd in sorted(listed - set(table)):
            problems.append("%s: the command table lists %s, which TABLE lacks" % (doc, cmd))
        for cmd in sorted(set(table) - listed):
            problems.append("%s: the command table lacks %s" % (doc, cmd))
    for i, (_n, line, _lang) in enumerate(code):
        if line.startswith("> "):
            cmd = line[2:].split()[0]
            reply = code[i + 1][1] if i + 1 < len(code) else ""
            if cmd not in table and "unknown_command" not in reply:
                problems.append("%s: example request %s is no protocol command" % (doc, cmd))
    return problems


# ---------------------------------------------------------------- the config table in docs/firmware.md

def _fmt_default(value):
    if value is None:
        return "null"
    if value is True or value is False:
        return "true" if value else "false"
    return str(value)


def config_row(key, entry):
    """The table's checked columns for one SCHEMA entry: key, default, type, range."""
    default, kind, lo, hi = entry
    if kind.startswith("choice:"):
        return "`%s`" % key, _fmt_default(default), "choice", ", ".join(kind[7:].split("|"))
    if kind == "bool_auto":
        return "`%s`" % key, _fmt_default(default), "bool or auto", "-"
    if kind in ("bool", "pin"):
        return "`%s`" % key, _fmt_default(default), kind, "-"
    if kind == "opt_float":
        return "`%s`" % key, _fmt_default(default), "float or null", "%s – %s" % (_fmt_default(lo), _fmt_default(hi))
    return "`%s`" % key, _fmt_default(default), kind, "%s – %s" % (_fmt_default(lo), _fmt_default(hi))


def config_table_rows(path):
    """{key: (cells)} of the `| key | default | type | range | ... |` table in docs/firmware.md."""
    rows, in_table = {}, False
    with open(path, encoding="utf-8") as fh:
        for line in fh:
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            if cells[:4] == ["key", "default", "type", "range"]:
                in_table = True
                continue
            if in_table:
                if not line.startswith("|"):
                    break
                if cells[0].startswith("`"):
                    rows[cells[0].strip("`")] = tuple(cells[:4])
    return rows


def check_config_table(schema, rows):
    problems = []
    for key, entry in schema.items():
        want = config_row(key, entry)
        if key not in rows:
            problems.append("docs/firmware.md: config table lacks %s (row: | %s |)" % (key, " | ".join(want)))
        elif rows[key] != want:
            problems.append("docs/firmware.md: config row %s reads %s, config.py says %s" % (key, rows[key], want))
    for key in rows:
        if key not in schema:
            problems.append("docs/firmware.md: config table lists %s, which SCHEMA lacks" % key)
    return problems
