"""README.md and docs/*.md held to the code: every name they give must exist.

What the docs name, and where the truth is read from:
- files and folders (`shared/quick.py`, tests/test_cli.py, [links](docs/x.md#anchor)): the tree;
- `fluxcal SUB --option`: the parsers of desktop.cli.build_parser();
- `python -m MODULE --option`, `make TARGET`: the module's add_argument calls, the Makefile;
- protocol commands (`start-cal`, `> status`): device/commands.py TABLE;
- config keys (`config set KEY`, the firmware.md table with defaults, types and ranges):
  device/config.py SCHEMA;
- Python names (`EllipsoidFit.solve`, `shared.coverage.Coverage`, `solve(prior=...)`, a
  ```python block): classes, functions, methods, keyword arguments and identifiers read by ast
  from the repository's code.
Each check has a test that plants a wrong name and sees it fail (test_*_catches_*).

    python tests/test_docs.py config-table    # the config table's key/default/type/range columns
"""

import ast
import fnmatch
import glob
import os
import re
import sys

import builtins

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)
BUILTINS = set(dir(builtins))
CODE_DIRS = ("shared", "device", "desktop", "tests")
TOP_DIRS = CODE_DIRS + ("docs",)
# names the docs may give that the repository's code does not define, each with its reason
ALLOWED = {
    "manifestfile.py": "MicroPython's freezing tool (tools/manifestfile.py in its source), cited as the format's origin",
    "../shared": "the interpreters' sources beside the repository, what `make interpreters` reads (Makefile)",
    "sys.implementation": "CPython/MicroPython built-in the deploy reads on the board",
    "gc.mem_alloc": "MicroPython built-in, the heap figures' source",
    "gc.mem_free": "MicroPython built-in",
    "gc.collect": "MicroPython/CPython built-in",
    "micropython.mem_info": "MicroPython built-in, the heap figures' source",
    "micropython.heap_lock": "MicroPython built-in the loop-back runner locks the heap with",
    "micropython.viper": "MicroPython's native code emitter, named as what was not tried",
    "json.loads": "the standard library's JSON parser the protocol uses",
    "machine.WDT": "MicroPython's watchdog, named as what the firmware does not start",
    "machine.Timer": "MicroPython's timer, named as what a watchdog feed would need",
    "time.ticks_*": "MicroPython's tick functions, which the HALs wrap",
    "sim-micropython": "a runtime name hal_sim.py builds as 'sim-' + sys.implementation.name",
    "summary.md": "a file `fluxcal report` writes into its output folder",
}


# ---------------------------------------------------------------- the docs, split into what they name

def doc_files():
    return [os.path.join(ROOT, "README.md")] + sorted(glob.glob(os.path.join(ROOT, "docs", "*.md")))


def _rel(path):
    return os.path.relpath(path, ROOT)


def parse_doc(path):
    """(prose lines, code lines, inline spans) of a markdown file, each with its line number.

    Code: fenced blocks (with their info string) and indented blocks after a blank line.
    Spans: `inline code` in prose (table cells included)."""
    prose, code, spans = [], [], []
    fence, lang, prev_blank, in_indented = None, "", True, False
    with open(path, encoding="utf-8") as fh:
        lines = fh.read().split("\n")
    for n, line in enumerate(lines, 1):
        stripped = line.strip()
        if fence is not None:
            if stripped.startswith(fence):
                fence = None
            else:
                code.append((n, line, lang))
            continue
        if stripped.startswith("```"):
            fence, lang = "```", stripped[3:].strip()
            continue
        if line.startswith("    ") and (prev_blank or in_indented) and not stripped.startswith(("-", "|")):
            in_indented = True
            code.append((n, line[4:], ""))
            continue
        in_indented = in_indented and not stripped
        prev_blank = not stripped
        prose.append((n, line))
        for m in re.finditer(r"(`+)(.+?)\1", line):
            spans.append((n, m.group(2).strip()))
    return prose, code, spans


# ---------------------------------------------------------------- the code's truth, read by ast

class CodeIndex:
    """Modules, classes (members, bases), functions (signatures) and every identifier or
    string word in the repository's Python files."""

    def __init__(self):
        self.modules = {}        # dotted name -> path ("shared.fit", device's flat "app")
        self.toplevel = {}       # dotted module -> set of names it defines or imports
        self.classes = {}        # class name -> [(members, bases)]
        self.functions = {}      # name -> [ast arguments] (functions and methods)
        self.methods = {}        # (class, name) -> [ast arguments]
        self.words = set()       # identifiers, attributes, string constants and their words
        self.options = {}        # path -> set of add_argument option strings
        for top in CODE_DIRS:
            for folder, dirs, names in os.walk(os.path.join(ROOT, top)):
                dirs[:] = [d for d in dirs if d != "__pycache__"]
                for name in names:
                    if name.endswith(".py") and name != "test_docs.py":   # not its own planted names
                        self._read(os.path.join(folder, name))

    def _read(self, path):
        rel = _rel(path)[:-3].replace(os.sep, "/")
        dotted = rel.replace("/", ".")
        if dotted.endswith(".__init__"):
            dotted = dotted[:-9]
        self.modules[dotted] = path
        if rel.startswith("device/"):
            self.modules[rel.split("/")[-1]] = path   # deployed flat, the firmware imports `app`
        with open(path, encoding="utf-8") as fh:
            tree = ast.parse(fh.read(), path)
        top = set()
        for node in tree.body:
            if isinstance(node, (ast.FunctionDef, ast.ClassDef, ast.AsyncFunctionDef)):
                top.add(node.name)
            elif isinstance(node, (ast.Assign, ast.AnnAssign)):
                for t in (node.targets if isinstance(node, ast.Assign) else [node.target]):
                    for n in ast.walk(t):
                        if isinstance(n, ast.Name):
                            top.add(n.id)
            elif isinstance(node, (ast.Import, ast.ImportFrom)):
                top.update((a.asname or a.name).split(".")[0] for a in node.names)
        self.toplevel[dotted] = top
        if rel.startswith("device/"):
            self.toplevel[rel.split("/")[-1]] = top
        options = set()
        for node in ast.walk(tree):
            if isinstance(node, ast.ClassDef):
                members = set()
                for item in ast.walk(node):
                    if isinstance(item, (ast.FunctionDef, ast.AsyncFunctionDef)):
                        members.add(item.name)
                    elif isinstance(item, ast.Attribute) and isinstance(item.value, ast.Name) \
                            and item.value.id == "self":
                        members.add(item.attr)
                for item in node.body:
                    if isinstance(item, (ast.FunctionDef, ast.AsyncFunctionDef)):
                        self.methods.setdefault((node.name, item.name), []).append(item.args)
                    if isinstance(item, ast.Assign):
                        members.update(t.id for t in item.targets if isinstance(t, ast.Name))
                bases = [b.id if isinstance(b, ast.Name) else getattr(b, "attr", "?") for b in node.bases]
                self.classes.setdefault(node.name, []).append((members, bases))
                self.words.add(node.name)
            elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                self.functions.setdefault(node.name, []).append(node.args)
                self.words.add(node.name)
                self.words.update(a.arg for a in node.args.args + node.args.kwonlyargs)
            elif isinstance(node, ast.Name):
                self.words.add(node.id)
            elif isinstance(node, ast.Attribute):
                self.words.add(node.attr)
            elif isinstance(node, ast.keyword) and node.arg:
                self.words.add(node.arg)
            elif isinstance(node, (ast.Import, ast.ImportFrom)):
                for a in node.names:
                    self.words.update(a.name.split("."))
                    if a.asname:
                        self.words.add(a.asname)
            elif isinstance(node, ast.Constant) and isinstance(node.value, str):
                self.words.add(node.value)
                self.words.update(re.findall(r"[A-Za-z_][\w-]*", node.value))
            if isinstance(node, ast.Call) and getattr(node.func, "attr", None) == "add_argument":
                options.update(a.value for a in node.args if isinstance(a, ast.Constant)
                               and isinstance(a.value, str) and a.value.startswith("-"))
        self.options[path] = options

    def class_has(self, cls, member, seen=()):
        """Whether class `cls` (or a base defined here) has `member`; None if cls is unknown."""
        if cls not in self.classes:
            return None
        for members, bases in self.classes[cls]:
            if member in members:
                return True
            for base in bases:
                if base not in seen and self.class_has(base, member, seen + (cls,)):
                    return True
                if base not in self.classes and member in self.words:
                    return True     # a base from outside (Exception, ...): its own members
        return False

    def resolve(self, dotted):
        """Problem with a dotted Python name, or None when it exists."""
        parts = dotted.split(".")
        for cut in range(len(parts), 0, -1):      # the longest module prefix
            mod = ".".join(parts[:cut])
            if mod in self.modules:
                rest = parts[cut:]
                if not rest:
                    return None
                if rest[0] not in self.toplevel[mod]:
                    return "%s has no %s" % (mod, rest[0])
                return self._members(rest)
        if parts[0] in ("shared", "desktop", "device", "tests"):
            return "no module %s" % dotted
        return self._members(parts)

    def _members(self, parts):
        head = parts[0]
        if head[:1].isupper() and any(c.islower() for c in head):     # a class name
            if head in BUILTINS:
                return None
            if head not in self.classes:
                return "no class %s" % head
            for i, member in enumerate(parts[1:]):
                owner = parts[i]
                if owner in self.classes and not self.class_has(owner, member):
                    return "class %s has no %s" % (owner, member)
                if owner not in self.classes and member not in self.words:
                    return "no name %s" % member
            return None
        missing = [p for p in parts if p not in self.words]
        return "no name %s" % ", ".join(missing) if missing else None

    def signatures(self, cls, name, seen=()):
        """The signatures of cls.name (its own, else its bases')."""
        if (cls, name) in self.methods:
            return self.methods[(cls, name)]
        for _members, bases in self.classes.get(cls, ()):
            for base in bases:
                if base not in seen:
                    found = self.signatures(base, name, seen + (cls,))
                    if found:
                        return found
        return []

    def accepts(self, name, positional, keywords, cls=None):
        """Problem when no function `name` (of class cls, if given) takes these arguments
        (None: one does, or none is known). A name that several define: a **kwargs
        signature counts only when no other is there (it takes anything)."""
        sigs = self.signatures(cls, name) if cls else self.functions.get(name, [])
        if not sigs:
            return None
        if not cls and any(not s.kwarg for s in sigs):
            sigs = [s for s in sigs if not s.kwarg]
        for sig in sigs:
            names = [a.arg for a in sig.args + sig.kwonlyargs]
            if names[:1] in (["self"], ["cls"]):
                names = names[1:]
                n_pos = len(sig.args) - 1
            else:
                n_pos = len(sig.args)
            if (positional <= n_pos or sig.vararg) and (sig.kwarg or all(k in names for k in keywords)):
                return None
        return "no %s(...) takes %d positional and %s" % (name, positional, ", ".join(keywords) or "no keywords")


@pytest.fixture(scope="module")
def index():
    return CodeIndex()


@pytest.fixture(scope="module")
def docs():
    return {_rel(p): parse_doc(p) for p in doc_files()}


# ---------------------------------------------------------------- checks: each returns its problems

PATH_RE = re.compile(r"(?<![\w./$-])((?:\.\./)?(?:%s)/[\w./*-]*)" % "|".join(TOP_DIRS))
FILE_RE = re.compile(r"(?<![\w/.$-])([\w-]+\.(?:py|md))\b")
EXISTS_CACHE = {}


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
        if path.startswith("../"):
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
    for m in re.finditer(r"(?<![\w-])make ([a-z]+)\b", line):
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


# ---------------------------------------------------------------- the tests

def all_problems(docs, index):
    subs, table, schema = fluxcal_parsers(), command_table(), config_schema()
    problems = []
    for doc, (prose, code, spans) in docs.items():
        text = "\n".join(line for _n, line in prose) + "\n" + "\n".join(line for _n, line, _l in code)
        problems += check_paths(doc, text)
        problems += check_links(doc, "\n".join(line for _n, line in prose))
        problems += check_section_names(doc, "\n".join(line for _n, line in prose))
        for n, span in spans:
            problems += ["%s (line %d)" % (p, n) for p in check_span(doc, span, index, subs, table, schema)]
        for n, line, lang in code:
            problems += ["%s (line %d)" % (p, n) for p in check_command(doc, line, subs, index)]
        blocks = {}
        for n, line, lang in code:
            if lang == "python":
                blocks.setdefault(lang, []).append(line)
        if blocks:
            problems += check_python_block(doc, "\n".join(blocks["python"]), index)
        problems += check_protocol_doc(doc, prose, code, table)
    problems += check_config_table(schema, config_table_rows(os.path.join(ROOT, "docs", "firmware.md")))
    return problems


def test_docs_name_only_what_exists(docs, index):
    problems = all_problems(docs, index)
    assert not problems, "%d names in the docs the code lacks:\n" % len(problems) + "\n".join(problems)


def test_docs_give_no_issue_numbers_or_history(docs):
    """Users read the docs: history and issue numbers go to CHANGELOG.md."""
    found = []
    for doc, (prose, code, _spans) in docs.items():
        for n, line in prose:
            if re.search(r"\bissues? \d+", line, re.I):
                found.append("%s:%d: %s" % (doc, n, line.strip()[:100]))
    assert not found, "issue numbers in the docs:\n" + "\n".join(found)


def test_readme_is_short():
    with open(os.path.join(ROOT, "README.md"), encoding="utf-8") as fh:
        assert len(fh.read().splitlines()) <= 200, "README.md over 200 lines: move detail to docs/"



def code_doc_citations(text):
    return re.findall(r"\b(?:docs/[\w./-]+\.(?:md|png)|README\.md|CHANGELOG\.md)", text)


def test_code_cites_only_docs_that_exist():
    """A comment or docstring that sends the reader to docs/NAME.md: the file is there."""
    missing = []
    for top in CODE_DIRS:
        for folder, dirs, names in os.walk(os.path.join(ROOT, top)):
            for name in names:
                if name.endswith(".py") and name != "test_docs.py":    # its planted names
                    path = os.path.join(folder, name)
                    with open(path, encoding="utf-8") as fh:
                        for cited in code_doc_citations(fh.read()):
                            if not os.path.exists(os.path.join(ROOT, cited)):
                                missing.append("%s cites %s" % (_rel(path), cited))
    assert not missing, "\n".join(missing)
    assert code_doc_citations("see docs/experiments.md, lag") == ["docs/experiments.md"]   # what it finds


def firmware_table_files(path):
    """The .py names in the first column of docs/firmware.md's `| file | what |` table."""
    names, in_table = set(), False
    with open(path, encoding="utf-8") as fh:
        for line in fh:
            if line.startswith("| file | what |"):
                in_table = True
            elif in_table and not line.startswith("|"):
                break
            elif in_table:
                first = line.strip().strip("|").split("|")[0]
                names.update(os.path.basename(n) for n in re.findall(r"`([\w/]+\.py)`", first))
    return names


def test_firmware_doc_has_a_row_for_every_firmware_file():
    """docs/firmware.md's module table: one row (or a shared row) per file under device/."""
    files = {n for _d, _s, names in os.walk(os.path.join(ROOT, "device")) for n in names
             if n.endswith(".py") and n != "__init__.py"}
    listed = firmware_table_files(os.path.join(ROOT, "docs", "firmware.md"))
    assert listed == files, "not in the table: %s; not in device/: %s" % (sorted(files - listed), sorted(listed - files))


def test_readme_command_table_lists_every_subcommand():
    """The README's table of commands: one row per `fluxcal` subcommand, none invented."""
    with open(os.path.join(ROOT, "README.md"), encoding="utf-8") as fh:
        text = fh.read()
    listed = re.findall(r"^\| `fluxcal ([a-z-]+)", text, re.M)
    assert sorted(listed) == sorted(fluxcal_parsers()), (sorted(listed), sorted(fluxcal_parsers()))


# every check, shown to fail on a planted wrong name (the same functions the doc test runs)

def _planted(index, text, lang="", doc="planted.md"):
    subs, table, schema = fluxcal_parsers(), command_table(), config_schema()
    problems = check_paths(doc, text) + check_links(doc, text) + check_section_names(doc, text)
    for span in re.findall(r"`([^`]+)`", text):
        problems += check_span(doc, span, index, subs, table, schema)
    if lang == "python":
        problems += check_python_block(doc, text, index)
    return problems


@pytest.mark.parametrize("right, wrong", [
    ("`shared/quick.py`", "`shared/quik.py`"),
    ("see tests/test_cli.py", "see tests/test_clii.py"),
    ("`app.py`", "`apps.py`"),
    ("[x](docs/protocol.md#status)", "[x](docs/protocol.md#statuses)"),
    ("[x](docs/protocol.md)", "[x](docs/experiments.md)"),
    ('docs/simulator.md, "Sensor lag"', 'docs/simulator.md, "Sensor drag"'),
    ('(README, "Layout")', '(README, "The command line")'),
    ("`docs/firmware.md`", "`../shared/reference/ads1292-and-runtimes.md`"),
    ("`fluxcal fit --prior OLD.json`", "`fluxcal fit --priors OLD.json`"),
    ("`fluxcal calibrate --quick`", "`fluxcal calibrat --quick`"),
    ("`fluxcal fit RAW --method streaming|mle`", "`fluxcal fit RAW --method streaming|lsq`"),
    ("`fluxcal experiment lag -o DIR`", "`fluxcal experiment drag -o DIR`"),
    ("`fluxcal emulate --runtime micropython-reprc`", "`fluxcal emulate --runtime micropython-repr`"),
    ("`python -m desktop.bench.cortexm --before e405f90`", "`python -m desktop.bench.cortexm --after e405f90`"),
    ("`python -m desktop.bench.fuzz`", "`python -m desktop.bench.fuzzer`"),
    ("`make demo`", "`make demos`"),
    ("`--accept-anyway`", "`--accept-always`"),
    ("`start-cal`", "`begin-cal`"),
    ("`config set survey_hz 10`", "`config set survey_rate 10`"),
    ("`EllipsoidFit.solve`", "`EllipsoidFit.solver`"),
    ("`shared.coverage.Coverage`", "`shared.coverage.Coverages`"),
    ("`WarmupFit`", "`WarmUpFit`"),
    ("`fit_tempco`", "`fit_temp_co`"),
    ("`not_better`", "`not_improved`"),
    ("`commands.status`", "`commands.cmd_status`"),
    ("`rej_*`", "`cmd_*`"),
    ("`solve(prior=previous)`", "`solve(prior_cal=previous)`"),
])
def test_each_check_catches_a_planted_wrong_name(index, right, wrong):
    assert not _planted(index, right), _planted(index, right)
    assert _planted(index, wrong), "%s passed" % wrong


def test_firmware_doc_check_catches_a_bare_name_from_elsewhere(index):
    """In docs/firmware.md `app.py` is the firmware's; `emulate.py` (desktop/cli/) needs its path."""
    assert not _planted(index, "`app.py`, desktop/cli/emulate.py", doc="docs/firmware.md")
    assert _planted(index, "`emulate.py`", doc="docs/firmware.md")
    assert not _planted(index, "`emulate.py`", doc="docs/cli.md")


def test_python_block_check_catches_a_changed_signature(index):
    good = "from shared.fit import EllipsoidFit\nfit = EllipsoidFit()\ncal = fit.solve(field=None, scale=1.0)\n"
    assert not _planted(index, good, "python")
    assert _planted(index, good.replace("scale=", "units="), "python")
    assert _planted(index, good.replace("EllipsoidFit\n", "EllipsoidFitter\n", 1), "python")


def test_protocol_check_catches_a_missing_or_invented_command():
    table = command_table()
    rows = [(0, "| command | reply | errors |")] + [(1, "| `%s` | x | y |" % c) for c in table]
    assert not check_protocol_doc("docs/protocol.md", rows, [], table)
    assert check_protocol_doc("docs/protocol.md", rows[:1] + rows[2:], [], table)          # one missing
    assert check_protocol_doc("docs/protocol.md", rows + [(9, "| `reboot` | x | y |")], [], table)
    assert check_protocol_doc("x.md", [], [(1, "> reboot", ""), (2, "{}", "")], table)


def test_config_check_catches_a_wrong_default_range_or_key():
    schema = config_schema()
    rows = {k: config_row(k, e) for k, e in schema.items()}
    assert not check_config_table(schema, rows)
    for key, bad in (("rate", ("`rate`", "2000", "int", "125 – 8000")),
                     ("decim", ("`decim`", "10", "int", "1 – 255")),
                     ("log", ("`log`", "false", "int", "-"))):
        assert check_config_table(schema, dict(rows, **{key: bad}))
    assert check_config_table(schema, dict(rows, survey_rate=rows["survey_hz"]))
    del rows["survey_hz"]
    assert check_config_table(schema, rows)


if __name__ == "__main__":
    if sys.argv[1:] == ["config-table"]:
        for key, entry in config_schema().items():
            print("| %s |  |" % " | ".join(config_row(key, entry)))
    else:
        print(__doc__)
