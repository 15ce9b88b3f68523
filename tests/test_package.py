"""The package as a whole: no import cycle among its modules (imports inside
functions count), and no import of its own modules hidden in a function unless it is
lazy on purpose, which its line says ("lazy"); and every public name documented with an
example (the examples run as doctests)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "geostructure"


def module_names() -> dict[str, Path]:
    names = {}
    for path in PACKAGE.rglob("*.py"):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        names[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return names


MODULES = module_names()


def imported(module: str, node: ast.ImportFrom | ast.Import) -> list[str]:
    """The package modules an import statement of ``module`` loads."""
    if isinstance(node, ast.Import):
        return [a.name for a in node.names if a.name in MODULES]
    package = module if MODULES[module].name == "__init__.py" else module.rsplit(".", 1)[0]
    if node.level:
        base = package.split(".")[: len(package.split(".")) - node.level + 1]
        target = ".".join(base + ([node.module] if node.module else []))
    else:
        target = node.module or ""
    found = [f"{target}.{a.name}" if f"{target}.{a.name}" in MODULES else target for a in node.names]
    return [name for name in found if name in MODULES and name != module]


def graph() -> dict[str, set[str]]:
    edges = {}
    for module, path in MODULES.items():
        edges[module] = {
            t
            for node in ast.walk(ast.parse(path.read_text()))
            if isinstance(node, (ast.Import, ast.ImportFrom))
            for t in imported(module, node)
        }
    return edges


def cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan)."""
    index, low, stack, on_stack, found = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in edges[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in edges:
        if v not in index:
            visit(v)
    return found


def test_the_checker_finds_a_cycle():
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_no_import_cycle_among_the_packages_modules():
    assert cycles(graph()) == []


def test_imports_of_the_package_inside_functions_are_lazy_on_purpose():
    hidden = []
    for module, path in MODULES.items():
        lines = path.read_text().splitlines()
        for function in ast.walk(ast.parse(path.read_text())):
            if not isinstance(function, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            for node in ast.walk(function):
                if isinstance(node, (ast.Import, ast.ImportFrom)) and imported(module, node):
                    said = " ".join(lines[max(0, node.lineno - 3) : node.lineno])  # its line or the two above
                    if "lazy" not in said.lower():
                        hidden.append(f"{path.relative_to(PACKAGE)}:{node.lineno}")
    assert hidden == []


def test_every_public_name_has_a_docstring_with_an_example():
    import geostructure

    missing = [
        name
        for name in geostructure.__all__
        if name != "__version__" and ">>>" not in (getattr(geostructure, name).__doc__ or "")
    ]
    assert missing == []


@pytest.mark.parametrize("numpy_first", [False, True])
@pytest.mark.parametrize("chosen, expected", [(None, "False"), ("1", "True")])
def test_the_command_asks_numpy_for_small_pages_unless_the_user_chose(chosen, expected, numpy_first):
    """The command's start turns numpy's huge pages off (slow to touch on VMs that return
    freed memory to their host) but keeps a choice made with numpy's own switch."""
    import os
    import subprocess
    import sys

    probe = (
        ("import numpy;" if numpy_first else "")  # before: numpy's setter; after: the switch it reads
        + "import geostructure.__main__ as m; m.prefer_small_pages(); import numpy;"
        + "print(numpy._core.multiarray._set_madvise_hugepage(False))"  # returns the setting it replaces
    )
    env = {k: v for k, v in os.environ.items() if k != "NUMPY_MADVISE_HUGEPAGE"}
    if chosen is not None:
        env["NUMPY_MADVISE_HUGEPAGE"] = chosen
    done = subprocess.run([sys.executable, "-c", probe], env=env, capture_output=True, text=True, timeout=60)
    assert done.stdout.strip() == expected, done.stderr


@pytest.mark.parametrize("chosen", [None, "MALLOC_ARENA_MAX", "GLIBC_TUNABLES"])
def test_the_command_has_malloc_reuse_freed_memory_unless_the_user_chose(chosen):
    """On glibc the command's start keeps freed arrays for reuse (one arena, nothing mapped
    per allocation), and tells its worker processes through the environment; a user's own
    malloc settings are left as they are."""
    import os
    import subprocess
    import sys

    probe = (
        "import os, geostructure.__main__ as m; print(m.reuse_freed_memory(), "
        "os.environ.get('MALLOC_MMAP_MAX_'), os.environ.get('MALLOC_ARENA_MAX'))"
    )
    env = {k: v for k, v in os.environ.items() if not k.startswith("MALLOC_") and k != "GLIBC_TUNABLES"}
    if chosen is not None:
        env[chosen] = "2" if chosen.startswith("MALLOC") else "glibc.malloc.arena_max=2"
    done = subprocess.run([sys.executable, "-c", probe], env=env, capture_output=True, text=True, timeout=60)
    glibc = sys.platform.startswith("linux") and os.confstr("CS_GNU_LIBC_VERSION")
    if chosen is None and glibc:
        assert done.stdout.split() == ["True", "0", "1"], done.stderr
    else:
        assert done.stdout.split()[0] == "False", done.stderr
        assert done.stdout.split()[1:] == ["None", "2" if chosen == "MALLOC_ARENA_MAX" else "None"]


#: The parts of the package (its folders; the package's own ``__init__`` is "root") and the
#: parts each may import: the layers of docs/architecture.md, bottom up. No part imports one
#: above it, nothing but ``__main__`` imports the command line, and ``io`` imports no
#: measuring part.
#: What a workflow may call on: every part but the command line.
WORKFLOW_PARTS = {
    "core",
    "detect",
    "rockmass",
    "kinematics",
    "evaluation",
    "io",
    "stream",
    "report",
    "reconstruct",
    "errors",
}
ALLOWED = {
    "root": set(),
    "errors": set(),
    "core": {"errors"},
    "io": {"core", "errors", "root"},
    "detect": {"core", "errors"},
    "rockmass": {"core", "detect", "errors"},
    "kinematics": {"core", "detect", "rockmass", "errors"},
    "synthetic": {"core", "rockmass", "errors"},
    "reconstruct": {"core", "io", "errors"},
    "evaluation": {"core", "detect", "io", "rockmass", "errors"},  # rockmass: the circular windows, map and ours alike
    "stream": {"core", "detect", "io", "errors"},
    "report": {"core", "io", "rockmass", "kinematics", "reconstruct", "errors"},  # kinematics: what it draws
    "workflows": WORKFLOW_PARTS | {"synthetic"},  # synthetic: the demo's scene
    "testing": {"core", "detect", "evaluation", "synthetic", "io", "errors"},
    "cli": WORKFLOW_PARTS | {"synthetic", "workflows", "root"},
    "__main__": {"cli", "errors", "root"},
}


def part_of(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "root"


def part_edges(edges: dict[str, set[str]]) -> dict[tuple[str, str], list[str]]:
    found: dict[tuple[str, str], list[str]] = {}
    for module, targets in edges.items():
        for target in targets:
            if part_of(module) != part_of(target):
                found.setdefault((part_of(module), part_of(target)), []).append(f"{module} -> {target}")
    return found


def test_every_part_imports_only_the_parts_below_it():
    found = part_edges(graph())
    assert set(part_of(m) for m in MODULES) == set(ALLOWED)
    assert [lines for (a, b), lines in sorted(found.items()) if b not in ALLOWED[a]] == []


def test_the_layer_checker_finds_a_forbidden_import():
    found = part_edges({"geostructure.io.writers": {"geostructure.rockmass.mass"}, "geostructure.rockmass.mass": set()})
    assert [b not in ALLOWED[a] for a, b in found] == [True]


def test_at_most_eight_modules_lie_flat_in_the_package():
    flat = sorted(p.name for p in PACKAGE.glob("*.py"))
    assert len(flat) <= 8, flat


def test_the_public_edge_raises_the_error_of_its_kind(tmp_path):
    """Readers raise InputError, options ParameterError, outputs OutputError (issue 44: 118
    of 193 raises used the base class, and no reader raised InputError)."""
    from geostructure import InputError, OutputError, ParameterError, Params, read_cloud, save_measurement
    from geostructure.io.survey_files import read_tiles

    damaged = tmp_path / "c.ply"
    damaged.write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 5\nproperty float x\nend_header\n")
    text = tmp_path / "c.xyz"
    text.write_text("1 2\n")
    for path in (damaged, text, tmp_path / "missing.las"):
        with pytest.raises(InputError):
            read_cloud(path)
    with pytest.raises(InputError):
        read_tiles([damaged, text])
    with pytest.raises(ParameterError):
        Params(zeta=2.0)
    (tmp_path / "taken").write_text("a file where the folder goes")
    from geostructure import measure
    from geostructure.synthetic import observatory_scene

    result = measure(observatory_scene(20_000, seed=1).cloud)
    with pytest.raises(OutputError):
        save_measurement(result, tmp_path / "taken")


#: The parts whose public names are their ``__all__`` (imported on first use).
DOCUMENTED_PARTS = ("core", "detect", "rockmass", "kinematics", "evaluation", "workflows", "io", "stream", "synthetic")


@pytest.mark.parametrize("part", DOCUMENTED_PARTS)
def test_every_name_a_part_exports_has_a_numpydoc_docstring(part):
    """Parameters (when it takes any), Returns (a function), and Examples, which run as
    doctests: the public edge a notebook user reads (issue 44: 29 of 531 had Parameters)."""
    import importlib
    import inspect

    package = importlib.import_module(f"geostructure.{part}")
    assert package.__all__, part
    missing = []
    for name in package.__all__:
        obj = getattr(package, name)
        if not callable(obj):  # a constant: its comment says what it is
            continue
        doc = inspect.getdoc(obj) or ""
        takes = [p for p in inspect.signature(obj).parameters if p != "self"]
        wanted = ["Examples"] + (["Parameters"] if takes else []) + (["Returns"] if inspect.isfunction(obj) else [])
        missing += [f"{part}.{name}: {section}" for section in wanted if f"{section}\n--" not in doc]
        if ">>>" not in doc:
            missing.append(f"{part}.{name}: an example")
    assert missing == []


def test_the_docs_name_only_test_files_and_modules_that_exist():
    """README, docs/ and the changelog pointed to 33 test files that had moved, all nine in
    docs/guarantees.md (the page that maps each promise to its test)."""
    import re

    root = PACKAGE.parents[1]
    pages = [root / "README.md", root / "CHANGELOG.md", *sorted((root / "docs").glob("*.md"))]
    missing = [
        f"{page.name}: {path}"
        for page in pages
        for path in sorted(set(re.findall(r"tests/[A-Za-z0-9_/]*\.py", page.read_text(encoding="utf-8"))))
        if not (root / path).is_file()
    ]
    assert not missing, missing


def test_the_command_line_only_parses_and_prints():
    """Issue 54: every workflow in ``workflows/``; the command line under 1,200 lines."""
    lines = sum(len(p.read_text().splitlines()) for p in (PACKAGE / "cli").glob("*.py"))
    assert lines < 1200, lines
    measuring = {"geostructure.detect.pipeline", "geostructure.stream", "geostructure.rockmass.mass"}
    edges = graph()
    assert [(m, t) for m, targets in edges.items() if part_of(m) == "cli" for t in targets if t in measuring] == []


def test_a_detectors_name_is_compared_only_in_its_registry():
    """Issue 54: a new detector is one entry of ``detect/registry.py``; no module compares a
    detector's name (``detector == "voxel"``) but the registry and the parameters' check."""
    import re

    names = "|".join(("facets", "voxel"))
    compared = re.compile(rf"""(==|!=)\s*["']({names})["']|["']({names})["']\s*(==|!=)|detector\w*\s*(==|!=)""")
    found = [
        f"{path.relative_to(PACKAGE)}:{number}"
        for path in PACKAGE.rglob("*.py")
        if path.name != "registry.py"
        for number, line in enumerate(path.read_text().splitlines(), 1)
        if compared.search(line.split("#")[0])
    ]
    assert found == []


def test_the_architecture_page_names_every_module_and_only_modules_that_exist():
    """Issue 54: ``docs/architecture.md`` is the layout a newcomer reads: every module of the
    package in its table, and no module named there that is gone."""
    import re

    page = (PACKAGE.parents[1] / "docs" / "architecture.md").read_text()
    named = set(re.findall(r"`((?:[a-z_]+)/[a-z_0-9]+)(?:\.py)?`", page))
    modules = {f"{p.parent.name}/{p.stem}" for p in PACKAGE.glob("*/*.py") if p.stem != "__init__"}
    assert sorted(modules - named) == []
    gone = [n for n in named if n.split("/")[0] in {p.name for p in PACKAGE.iterdir()} and n not in modules]
    assert [n for n in gone if not (PACKAGE / n).is_dir() and not (PACKAGE / f"{n}.py").is_file()] == []
