"""One error tree: every exception class of parolkit is drawn in ``parolkit.errors``' docstring,
under its real base class, and no two exception classes share a name.

The classes are found statically (ast over ``src/parolkit``), so a new exception anywhere in
the package, also in a module no test imports, fails here until it is drawn in the tree.
"""

from __future__ import annotations

import ast
from dataclasses import dataclass
from pathlib import Path

import parolkit.errors

PACKAGE = Path(parolkit.errors.__file__).resolve().parent
#: Builtin bases an exception class may have (only those drawn in the tree's root lines).
BUILTIN_ROOTS = {"Exception", "BaseException", "ValueError", "OSError", "RuntimeError"}


@dataclass(frozen=True)
class ExcClass:
    name: str
    module: str
    bases: tuple[str, ...]


def _module_name(path: Path) -> str:
    rel = path.relative_to(PACKAGE.parent).with_suffix("")
    parts = rel.parts[:-1] if rel.name == "__init__" else rel.parts
    return ".".join(parts)


def _classes() -> list[ExcClass]:
    out = []
    for path in sorted(PACKAGE.rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
        for node in ast.walk(tree):
            if isinstance(node, ast.ClassDef):
                bases = tuple(ast.unparse(b).split(".")[-1] for b in node.bases)
                out.append(ExcClass(node.name, _module_name(path), bases))
    return out


def exception_classes() -> list[ExcClass]:
    """Every class whose bases lead (by name, within the package) to a builtin exception."""
    classes = _classes()
    by_name: dict[str, list[ExcClass]] = {}
    for c in classes:
        by_name.setdefault(c.name, []).append(c)
    known: set[str] = set()
    changed = True
    while changed:
        changed = False
        for c in classes:
            if c.name not in known and any(b in BUILTIN_ROOTS or b in known for b in c.bases):
                known.add(c.name)
                changed = True
    return [c for c in classes if c.name in known]


def drawn_tree() -> dict[str, str | None]:
    """name -> parent name, from the ``::`` drawing in parolkit.errors' docstring.

    A node is a line with ``+-- Name`` or a root line (a name at the drawing's left edge);
    its depth is the column of the name.  Every other line continues a comment."""
    doc = parolkit.errors.__doc__ or ""
    lines = doc.split("::", 1)[1].splitlines()
    while lines and not lines[0].strip():
        lines.pop(0)
    drawing = []
    for line in lines:
        if not line.strip():
            break  # the drawing ends at its first blank line
        drawing.append(line)
    edge = min(len(line) - len(line.lstrip()) for line in drawing)
    parents: dict[str, str | None] = {}
    stack: list[tuple[int, str]] = []  # (column, name) of the open branches
    for line in drawing:
        branch = line.find("+-- ")
        if branch >= 0:
            col, name = branch + 4, line[branch + 4:].split()[0]
        elif len(line) - len(line.lstrip()) == edge and line.split()[0].isidentifier():
            col, name = edge, line.split()[0]
        else:
            continue
        while stack and stack[-1][0] >= col:
            stack.pop()
        assert name not in parents, f"{name} is drawn twice in the parolkit.errors tree"
        parents[name] = stack[-1][1] if stack else None
        stack.append((col, name))
    return parents


def test_the_tree_is_drawn_with_its_root():
    tree = drawn_tree()
    assert tree["Exception"] is None
    assert tree["ParolkitError"] == "Exception"
    assert tree["CommandFailed"] == "CommandNotCompleted"


def test_every_exception_class_of_the_package_is_in_the_tree_under_its_base():
    tree = drawn_tree()
    doc = parolkit.errors.__doc__ or ""
    problems = []
    for c in exception_classes():
        if c.name.startswith("_"):  # private control flow: named in the docstring's prose
            if f"{c.module}.{c.name}" not in doc:
                problems.append(f"{c.module}.{c.name}: private exception not mentioned")
            continue
        if c.name not in tree:
            problems.append(f"{c.module}.{c.name} (bases {', '.join(c.bases)}) is not drawn")
        elif tree[c.name] != c.bases[0]:
            problems.append(f"{c.module}.{c.name} is drawn under {tree[c.name]}, "
                            f"but its first base is {c.bases[0]}")
    assert not problems, "parolkit.errors' tree is out of date:\n  " + "\n  ".join(problems)


def test_the_tree_draws_no_class_that_does_not_exist():
    names = {c.name for c in exception_classes()} | BUILTIN_ROOTS
    ghosts = sorted(set(drawn_tree()) - names)
    assert not ghosts, f"drawn in parolkit.errors but not defined anywhere: {ghosts}"


def test_no_two_exception_classes_share_a_name():
    seen: dict[str, list[str]] = {}
    for c in exception_classes():
        seen.setdefault(c.name, []).append(c.module)
    dupes = {n: m for n, m in seen.items() if len(m) > 1}
    assert not dupes, f"exception names defined more than once: {dupes}"


def test_the_old_client_command_error_name_is_a_deprecated_alias():
    import warnings

    from parolkit.client import errors

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        alias = errors.CommandError
    assert alias is errors.CommandNotCompleted
    assert any(issubclass(w.category, DeprecationWarning) and "CommandNotCompleted" in str(w.message)
               for w in caught)
