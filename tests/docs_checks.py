"""The doc checks of tests/test_docs.py: paths, links, sections, commands and Python names; each
returns its problems."""

import ast
import fnmatch
import glob
import os
import re
from tests.docs_index import (ALLOWED, ROOT, TOP_DIRS, _rel)

# ---------------------------------------------------------------- checks: each returns its problems

PATH_RE = re.compile(r"(?<![\w./$-])((?:\.\./)?(?:%s)/[\w./*-]*)" % "|".join(TOP_DIRS))
FILE_RE = re.compile(r"(?<![\w/.$-])([\w-]+\.(?:py|md))\b")
EXISTS_CACHE = {}
SHARED_DATA = "../shared/data/"     # the real recordings beside the repository (tests/shared_data.py)


def _basenames():
    if not EXISTS_CACHE:
        for top in TOP_DIRS + (".",):
            for folder, dirs, names in os.walk(os.path.join(ROOT, top)):
                dirs[:] = [d for d in dirs if not d.startswith(".") and d not in ("build", "__pycache__")]
                for name in names:
                    EXISTS_CACHE[name] = True
                if top == ".":
                    break
    return EXISTS_CACHE


# docs about the firmware: a bare file name there means a firmware file (device/, shared/), so
# `calibrate.py` cannot pass on desktop/cli/calibrate.py once the firmware's is gone
FIRMWARE_DOCS = ("docs/firmware.md", "docs/protocol.md", "docs/reliability.md")
FIRMWARE_DOC_OTHERS = {
    "device.py": "desktop/bench/device.py, named in the heap bench's own output table",
    "firmware_cost.py": "desktop/bench/micropython-scripts/firmware_cost.py, named in the device bench's output",
}


def _firmware_names():
    return {n for top in ("device", "shared") for _d, _s, names in os.walk(os.path.join(ROOT, top)) for n in names}


def check_paths(doc, text):
    """Every repository path (device/app.py, docs/x.md, globs) and bare file name (app.py) exists."""
    problems = []
    for m in PATH_RE.finditer(text):
        path = m.group(1).rstrip(".,;:)")
        if path in ALLOWED:
            continue
        if path.startswith(SHARED_DATA):
            # ../shared beside the repository, as in CI: its recordings must exist where it is
            if os.path.isdir(os.path.join(ROOT, "..", "shared")) and not os.path.exists(os.path.join(ROOT, path)):
                problems.append("%s: no file or folder %s" % (doc, path))
        elif path.startswith("../"):
            problems.append("%s: %s is outside the repository" % (doc, path))
        elif not glob.glob(os.path.join(ROOT, path)):
            problems.append("%s: no file or folder %s" % (doc, path))
    names = _basenames()
    for m in FILE_RE.finditer(text):
        name = m.group(1)
        if name not in names and name not in ALLOWED and not name[:1].isupper():   # CAL.json: a placeholder
            problems.append("%s: no file named %s" % (doc, name))
        elif doc in FIRMWARE_DOCS and name.endswith(".py") and name not in _firmware_names() \
                and name not in FIRMWARE_DOC_OTHERS:
            problems.append("%s: %s is no firmware file: give its path" % (doc, name))
    return problems


def _slug(heading):
    """GitHub's anchor of a heading: its rendered text, lower case, punctuation dropped."""
    s = re.sub(r"\[([^]]*)\]\([^)]*\)", r"\1", heading).replace("`", "").strip().lower()
    s = re.sub(r"[^\w\- ]", "", s)
    return s.replace(" ", "-")


def check_links(doc, text):
    """[text](target#anchor): the file exists and has the heading."""
    problems = []
    for m in re.finditer(r"\]\(([^)\s]+)\)", text):
        target = m.group(1)
        if re.match(r"[a-z]+://", target):
            continue
        path, _, anchor = target.partition("#")
        full = os.path.normpath(os.path.join(ROOT, os.path.dirname(doc), path)) if path else os.path.join(ROOT, doc)
        if not full.startswith(ROOT + os.sep) and full != ROOT:
            problems.append("%s: link %s leaves the repository" % (doc, target))
        elif not os.path.exists(full):
            problems.append("%s: link to a missing %s" % (doc, target))
        elif anchor and full.endswith(".md"):
            with open(full, encoding="utf-8") as fh:
                slugs = {_slug(h) for h in re.findall(r"^#+ (.*)$", fh.read(), re.M)}
            if anchor not in slugs:
                problems.append("%s: %s has no heading #%s" % (doc, path or doc, anchor))
    return problems


def _headings(path):
    with open(path, encoding="utf-8") as fh:
        return [re.sub(r"[`*]", "", h).strip().lower() for h in re.findall(r"^#+ (.*)$", fh.read(), re.M)]


def check_section_names(doc, text):
    """A section named in quotes (`docs/x.md, "Sensor lag"`, `"Missed conversions" below`) exists."""
    problems = []
    cited = [(m.group(1), m.group(2)) for m in
             re.finditer(r"(\b[\w/-]+\.md|README)\)?[,:]? \"([A-Z][^\"]{2,60})\"", text)]
    cited += [(doc, m.group(1) or m.group(2)) for m in
              re.finditer(r"\"([A-Z][^\"]{2,60})\" below|below, \"([A-Z][^\"]{2,60})\"", text)]
    for target, section in cited:
        if target == "README":
            target = "README.md"
        path = os.path.join(ROOT, target) if "/" in target or target == "README.md" or target == doc \
            else os.path.join(ROOT, os.path.dirname(doc), target)
        if not os.path.exists(path):
            continue        # a missing file is check_paths' or check_links' to report
        if not any(h.startswith(section.lower()) for h in _headings(path)):
            problems.append('%s: %s has no section "%s"' % (doc, target, section))
    return problems


def _options_in(text):
    """--long and -s options written in a command line ([--a|--b], --x=V, -o)."""
    out = []
    for token in text.split():
        for part in token.strip("[]()").split("|"):
            part = part.strip("[](),.;:'\"`")
            m = re.match(r"(--?[A-Za-z][\w-]*)", part)
            if m:
                out.append(m.group(1))
    return out


def fluxcal_parsers():
    from desktop.cli import build_parser
    parser = build_parser()
    subs = {}
    for action in parser._actions:
        if hasattr(action, "choices") and isinstance(action.choices, dict):
            for name, sub in action.choices.items():
                # option -> its choices (None: any value); None -> the positional's choices
                subs[name] = {o: a.choices for a in sub._actions for o in a.option_strings}
                subs[name][None] = next((a.choices for a in sub._actions
                                         if not a.option_strings and a.choices), None)
    return subs


def _values(token):
    """The words a doc gives as an option's values (`a|b`, `[a|b]`), or None for a placeholder."""
    parts = [p.strip("[](),.;:'\"`") for p in token.split("|")]
    if all(re.match(r"^[a-z][\w.-]*$", p) for p in parts):
        return parts
    return None


def _check_values(doc, sub, rest, choices):
    """Option values and the positional's among the parser's choices."""
    problems, tokens = [], rest.split()
    for i, token in enumerate(tokens):
        opt, _, inline = token.strip("[]").partition("=")
        if opt.startswith("-"):
            value = inline or (tokens[i + 1] if i + 1 < len(tokens) else "")
            allowed = choices.get(opt)
        elif i == 0 or not tokens[i - 1].strip("[]").startswith("-"):
            value, allowed = token, choices.get(None)
            if i:          # only the first positional is checked (NAME, RAW, ...)
                continue
        else:
            continue
        words = _values(value) if allowed and value and not value.startswith("-") else None
        for word in words or ():
            if word not in allowed:
                problems.append("%s: fluxcal %s %s: %s is not one of %s" % (doc, sub, opt if opt.startswith("-") else "",
                                                                              word, ", ".join(map(str, allowed))))
    return problems


def check_command(doc, line, subs, index):
    """A command line: `fluxcal SUB --opt`, `python -m MOD --opt`, `make TARGET`."""
    problems = []
    line = line.split("  #")[0].split(" # ")[0]
    for m in re.finditer(r"(?<![\w/.-])fluxcal ([a-z][\w-]*)((?: +[^ #`]+)*)", line):
        sub, rest = m.group(1), m.group(2)
        if sub not in subs:
            problems.append("%s: no fluxcal subcommand %s (%s)" % (doc, sub, line.strip()))
            continue
        for opt in _options_in(rest):
            if opt not in subs[sub]:
                problems.append("%s: fluxcal %s has no option %s" % (doc, sub, opt))
        problems += _check_values(doc, sub, rest, subs[sub])
    for m in re.finditer(r"python -m ([\w.]+)((?: +[^ #`]+)*)", line):
        mod, rest = m.group(1), m.group(2)
        path = index.modules.get(mod)
        if path and path.endswith("__init__.py") and os.path.exists(path[:-11] + "__main__.py"):
            path = path[:-11] + "__main__.py"
        if path is None:
            if not mod.startswith(("desktop", "shared", "device", "tests")):
                continue      # pytest, mpremote, pip: not ours
            problems.append("%s: no module %s" % (doc, mod))
            continue
        known = _module_options(path, index)
        for opt in _options_in(rest):
            if opt not in known:
                problems.append("%s: python -m %s has no option %s" % (doc, mod, opt))
    for m in re.finditer(r"(?<![\w-])make ([a-z][\w-]*)", line):   # pico-frozen too
        with open(os.path.join(ROOT, "Makefile")) as fh:
            targets = set(re.findall(r"^([\w-]+):", fh.read(), re.M))
        if m.group(1) not in targets:
            problems.append("%s: no make target %s" % (doc, m.group(1)))
    return problems


def _module_options(path, index):
    """add_argument options of a module and of the repository modules it imports."""
    known = set(index.options.get(path, ()))
    with open(path) as fh:
        tree = ast.parse(fh.read())
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                pkg = _rel(os.path.dirname(path)).replace(os.sep, ".")
                base = pkg + ("." + base if base else "")
            for a in node.names:
                for cand in (base + "." + a.name, base):
                    if cand in index.modules:
                        known |= index.options.get(index.modules[cand], set())
    return known


NAME_RE = re.compile(r"^([A-Za-z_]\w*(?:\.[A-Za-z_]\w*)*)(\((.*)\))?$")


def _call_args(text):
    """(positional count, keyword names) of the inside of a call written in the docs."""
    try:
        call = ast.parse("f(%s)" % text.replace("...", "x"), mode="eval").body
    except SyntaxError:
        return None
    return len(call.args), [k.arg for k in call.keywords if k.arg]


def check_span(doc, span, index, subs, table, schema):
    """One `inline code` span: a path, a command, a protocol command, a config key or a Python name."""
    problems = []
    if span in ALLOWED:
        return problems
    first = span.split()[0] if span.split() else ""
    if first in ("fluxcal", "python", "make") or "python -m" in span:
        return check_command(doc, span, subs, index)
    if first.startswith("--") and len(span.split()) <= 3:
        opts = _options_in(first)
        if opts and not any(opts[0] in o for o in subs.values()) and \
                not any(opts[0] in o for o in index.options.values()):
            problems.append("%s: option %s is no command's" % (doc, opts[0]))
        return problems
    if first == "config" and len(span.split()) >= 3 and span.split()[1] in ("set", "get"):
        key = span.split()[2]
        if key not in schema and not key.isupper():
            problems.append("%s: config key %s does not exist" % (doc, key))
        return problems
    if re.match(r"^[a-z]+(-[a-z]+)+$", first):      # a protocol command or another hyphenated word
        if first not in table and first not in subs and first not in index.words:
            problems.append("%s: %s is no protocol command, fluxcal subcommand or name in the code" % (doc, first))
        return problems
    if "*" in span and re.match(r"^[\w*.]+$", span) and "/" not in span:
        if not any(fnmatch.fnmatchcase(w, span) for w in index.words) and \
                not fnmatch.filter(_basenames(), span):
            problems.append("%s: nothing in the code matches %s" % (doc, span))
        return problems
    if re.search(r"\.(py|md|json|npz|csv|png|mpy|toml|txt|tmp|bak|log)$", span) or "/" in span:
        return problems          # files: check_paths
    m = NAME_RE.match(span)
    if not m or span.isdigit():
        return problems
    dotted, call, inside = m.group(1), m.group(2), m.group(3)
    if dotted in ALLOWED or dotted in schema or dotted in table:
        return problems
    problem = index.resolve(dotted)
    if problem:
        problems.append("%s: `%s`: %s" % (doc, span, problem))
    elif call is not None and inside not in (None, "", "..."):
        args = _call_args(inside)
        if args is not None:
            parts = dotted.split(".")
            name, cls = parts[-1], (parts[-2] if len(parts) > 1 and parts[-2] in index.classes else None)
            if name in index.classes:
                name, cls = "__init__", name
            problem = index.accepts(name, *args, cls=cls)
            if problem:
                problems.append("%s: `%s`: %s" % (doc, span, problem))
    return problems
