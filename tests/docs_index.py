"""What README.md and docs/*.md name, and the code's truth read by ast (tests/test_docs.py)."""

import ast
import glob
import os
import re
import sys
import builtins

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
