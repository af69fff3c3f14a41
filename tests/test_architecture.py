"""The house map, checked on the source (issue 36): the middle floor's packages import one another in one direction,
backends are built in one place, and an ampere changes unit in one module.

The import graph is read with ``ast`` from every module under ``src/spherestep``, imports inside functions counted
(a lazy import is still an arrow). ``docs/conventions.md`` (the house map) states the same rules in words.
"""

from __future__ import annotations

import ast
import functools
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src" / "spherestep"
MIDDLE = ("electrics", "magnetics", "sensing", "control", "dynamics", "hardware", "drive")
MOTOR_FLOOR = ("sphere", "so3", "packing", "harmonics", "motor", "design_file", "statics", "rotor_field", "potential",
               "commutation")
# The house map (docs/conventions.md), bottom to top: a room imports rooms of its own floor or below, never above.
FLOORS = (
    ("errors", "checks", "units", "lazy", "atomic", "outputs", "progress", "channels", "interrupts"),  # plumbing
    ("sphere", "so3", "packing", "harmonics", "_fast"),  # geometry
    ("motor", "design_file", "statics", "rotor_field", "potential", "commutation", "fig10"),  # the motor
    ("electrics",), ("magnetics",), ("sensing",), ("control",), ("dynamics",), ("hardware",), ("drive",),
    ("gallery", "explore", "synthesis", "report", "plots", "demo", "export", "cli"),  # applications
)
# File circles (two or more modules importing one another, imports inside functions counted), each declared with
# the one concept its files share (docs/conventions.md, the house map's declared exceptions).
FILE_CIRCLES = {
    ("spherestep.control.time_optimal", "spherestep.control.trajectory"): "a turn planned in time",
    ("spherestep.magnetics._ironmap", "spherestep.magnetics._ironscale"): "the iron model and its scaled tables",
}
BACKENDS = {"LockstepLink", "DriveLink", "PtyDevice", "MotorPty", "Simulated", "DryRun", "Serial", "SerialPort",
            "EmulatedMotor", "RelayLink"}
SELECTOR = SRC / "drive" / "connect.py"
ELECTRICS = SRC / "electrics.py"
CURRENTISH = re.compile(r"(^|_)(ma|amps?|amperes?|currents?)($|_)|nominal|current", re.IGNORECASE)


@functools.cache
def _tree(path: Path) -> ast.Module:
    """The parsed source of ``path``, read once per test session (every check walks the same files)."""
    return ast.parse(path.read_text(encoding="utf-8"))


def _module(path: Path) -> tuple[str, bool]:
    """``(dotted name, is a package's __init__)`` of a file under ``src``."""
    parts = list(path.relative_to(SRC.parent).with_suffix("").parts)
    package = parts[-1] == "__init__"
    return ".".join(parts[:-1] if package else parts), package


def _type_only(tree) -> set[int]:
    """``id`` of every node under an ``if TYPE_CHECKING:`` block (imports for annotations only: never run)."""
    out: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and _names(node.test)[-1:] == ["TYPE_CHECKING"]:
            out |= {id(n) for stmt in node.body for n in ast.walk(stmt)}
    return out


@functools.cache
def _imports(path: Path) -> list[tuple[str, int]]:
    """Every ``spherestep`` module (or name in one) ``path`` imports when it runs, anywhere in the file (inside
    functions too), with its line; an import under ``if TYPE_CHECKING:`` is for annotations only and not counted."""
    name, package = _module(path)
    base = name.split(".") if package else name.split(".")[:-1]
    out = []
    tree = _tree(path)
    skip = _type_only(tree)
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.Import):
            out += [(a.name, node.lineno) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                target = ".".join(base[:len(base) - node.level + 1] + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            out.append((target, node.lineno))
            out += [(f"{target}.{a.name}", node.lineno) for a in node.names]
    return [(t, line) for t, line in out if t.startswith("spherestep.")]


def _room(dotted: str) -> str | None:
    """The top-level room of ``spherestep.room...`` (None for the package itself)."""
    parts = dotted.split(".")
    return parts[1] if len(parts) > 1 else None


def package_graph(rooms=MIDDLE) -> dict[tuple[str, str], list[str]]:
    """``(room a, room b) -> ["module:line", ...]`` for every import from ``a`` into ``b`` among ``rooms``."""
    edges: dict[tuple[str, str], list[str]] = {}
    for path in SRC.rglob("*.py"):
        name, _ = _module(path)
        a = _room(name)
        if a not in rooms:
            continue
        for target, line in _imports(path):
            b = _room(target)
            if b in rooms and b != a:
                edges.setdefault((a, b), []).append(f"{name}:{line}")
    return edges


def _cycle(edges) -> list[str] | None:
    """One cycle of the directed graph ``edges`` (a list of nodes, first repeated last), or None."""
    succ: dict[str, set[str]] = {}
    for a, b in edges:
        succ.setdefault(a, set()).add(b)
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(n):
        state[n] = 1
        stack.append(n)
        for m in sorted(succ.get(n, ())):
            if state.get(m) == 1:
                return stack[stack.index(m):] + [m]
            if m not in state and (found := visit(m)):
                return found
        stack.pop()
        state[n] = 2
        return None

    for n in sorted(succ):
        if n not in state and (found := visit(n)):
            return found
    return None


def test_the_cycle_finder_finds_a_planted_cycle():
    """The checker can fail: a graph with a cycle is reported, one without is not."""
    assert _cycle({("a", "b"): [], ("b", "c"): [], ("c", "a"): []}) == ["a", "b", "c", "a"]
    assert _cycle({("a", "b"): [], ("b", "c"): [], ("a", "c"): []}) is None


def rooms() -> list[str]:
    """Every top-level module and package under ``src/spherestep``."""
    return sorted({_room(_module(p)[0]) for p in SRC.rglob("*.py")} - {None})


def upward(edges, floors=FLOORS) -> list[str]:
    """The arrows of ``edges`` that point to a higher floor than their room's, ``"a->b at module:line"``."""
    floor = {room: k for k, names in enumerate(floors) for room in names}
    return [f"{a}->{b} at {', '.join(where)}" for (a, b), where in sorted(edges.items()) if floor[b] > floor[a]]


def test_every_room_is_on_a_floor_and_none_imports_upward():
    """The house map covers every room (a new one must be placed), and no import — inside a function or not —
    points to a higher floor. The checker can fail: a planted upward arrow is reported."""
    placed = {room for names in FLOORS for room in names}
    assert set(rooms()) == placed, (sorted(set(rooms()) - placed), sorted(placed - set(rooms())))
    found = upward(package_graph(tuple(rooms())))
    assert not found, "import to a higher floor: " + "; ".join(found)
    assert upward({("commutation", "dynamics"): ["planted:1"], ("dynamics", "commutation"): []}) == \
        ["commutation->dynamics at planted:1"]


def test_no_package_cycle_anywhere():
    """No cycle among all the rooms of ``src/spherestep``, function-level imports counted (issue 36): the
    commutation room's iron planner once imported dynamics (its settling check) and hardware (its heat) while both
    import the plan; its checks are now handed in (``Tuning.released``, ``ThermalLimits.guard``)."""
    edges = package_graph(tuple(rooms()))
    cycle = _cycle(edges)
    assert cycle is None, "package cycle " + " -> ".join(cycle) + ": " + "; ".join(
        f"{a}->{b} at {', '.join(edges[(a, b)])}" for a, b in zip(cycle, cycle[1:]))


def file_graph() -> dict[str, set[str]]:
    """Module → the modules it imports (inside functions too; a name imported from a package resolved to the
    package's ``__init__``, which is left out as a target: a package re-exports, it is not a concept)."""
    modules = {_module(p)[0]: _module(p)[1] for p in SRC.rglob("*.py")}
    succ: dict[str, set[str]] = {}
    for p in SRC.rglob("*.py"):
        name = _module(p)[0]
        for target, _ in _imports(p):
            parts = target.split(".")
            while parts and ".".join(parts) not in modules:
                parts.pop()
            m = ".".join(parts)
            if m and m != name and not modules[m]:
                succ.setdefault(name, set()).add(m)
    return succ


def circles(succ) -> list[tuple[str, ...]]:
    """The strongly connected sets of two or more nodes of ``succ`` (Tarjan), each sorted, in sorted order."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    out = []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in sorted(succ.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(tuple(sorted(comp)))

    for v in sorted(succ):
        if v not in index:
            visit(v)
    return sorted(out)


def test_file_circles_are_only_the_declared_ones():
    """Import-level file circles only where the files are one concept (issue 36): the circles found are exactly
    :data:`FILE_CIRCLES`, each two files. The finder can fail: a planted three-file circle is found."""
    assert circles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [("a", "b", "c")]
    found = circles(file_graph())
    assert found == sorted(FILE_CIRCLES), [c for c in found if c not in FILE_CIRCLES] or sorted(FILE_CIRCLES)
    assert all(len(c) == 2 for c in found)


def test_the_middle_floor_has_no_package_cycle():
    """No cycle among electrics, magnetics, sensing, control, dynamics, hardware and drive, function-level imports
    counted; the arrows that once tied the knot are gone (control → dynamics/drive/hardware, magnetics → control,
    hardware → control/dynamics/sensing)."""
    edges = package_graph()
    cycle = _cycle(edges)
    assert cycle is None, "package cycle " + " -> ".join(cycle) + ": " + "; ".join(
        f"{a}->{b} at {', '.join(edges[(a, b)])}" for a, b in zip(cycle, cycle[1:]))
    for a, b in (("control", "dynamics"), ("control", "drive"), ("control", "hardware"), ("magnetics", "control"),
                 ("hardware", "control"), ("hardware", "dynamics"), ("hardware", "sensing"),
                 ("electrics", "magnetics"), ("electrics", "control")):
        assert (a, b) not in edges, f"{a} imports {b} at {edges[(a, b)]}"


def test_the_motor_floor_has_no_package_cycle():
    """The design and its file (issue 36): ``motor`` calls ``design_file`` to read and write itself and
    ``design_file`` names ``MotorDesign`` in annotations only (under ``if TYPE_CHECKING:``), so no arrow points
    back; no cycle among the rooms of the geometry and motor floors either. A planted run-time import is seen."""
    edges = package_graph(MOTOR_FLOOR)
    assert _cycle(edges) is None, _cycle(edges)
    assert ("motor", "design_file") in edges and ("design_file", "motor") not in edges
    tree = ast.parse("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from ..motor import A\n"
                     "def f():\n    from ..motor import B\n")
    skipped = _type_only(tree)
    kept = [n.names[0].name for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and id(n) not in skipped]
    assert kept == ["TYPE_CHECKING", "B"]


def _calls(path: Path):
    """``(name, line)`` of every call by a bare or dotted name in ``path`` (docstrings and comments ignored)."""
    for node in ast.walk(_tree(path)):
        if isinstance(node, ast.Call):
            f = node.func
            if isinstance(f, ast.Name):
                yield f.id, node.lineno
            elif isinstance(f, ast.Attribute) and not (isinstance(f.value, ast.Name) and f.value.id == "pyserial"):
                yield f.attr, node.lineno


def _sources():
    return [p for p in [*SRC.rglob("*.py"), *(ROOT / "scripts").rglob("*.py")] if p.is_file()]


def test_backends_are_built_only_by_the_selector():
    """No ``LockstepLink(``, ``DriveLink(``, ``PtyDevice(``, ``MotorPty(``, ``Simulated(``, ``DryRun(``,
    ``Serial(``, ``EmulatedMotor(`` outside ``spherestep.drive.connect`` in src/ and scripts/ (tests may)."""
    found = [f"{p.relative_to(ROOT)}:{line} {name}(" for p in _sources() if p != SELECTOR
             for name, line in _calls(p) if name in BACKENDS]
    assert not found, "backend built outside spherestep.drive.connect: " + "; ".join(found)
    assert {name for name, _ in _calls(SELECTOR)} >= {"LockstepLink", "DriveLink", "MotorPty", "Simulated",
                                                       "DryRun", "Serial", "EmulatedMotor", "RelayLink"}


def _names(node) -> list[str]:
    return [n.id if isinstance(n, ast.Name) else n.attr for n in ast.walk(node)
            if isinstance(n, (ast.Name, ast.Attribute))]


def conversions(path: Path) -> list[str]:
    """The unit conversions of a coil current in ``path``: ``x * / ** nominal_current`` either way round, and a
    current-like operand (``ma``, ``amps``, ``current``...) times or over 1000 (a bare ``i`` is too common a
    name to judge by)."""
    out = []
    for node in ast.walk(_tree(path)):
        if not isinstance(node, ast.BinOp) or not isinstance(node.op, (ast.Mult, ast.Div, ast.Pow)):
            continue
        sides = (node.left, node.right)
        if any(isinstance(s, (ast.Name, ast.Attribute)) and _names(s)[0] == "nominal_current" for s in sides):
            out.append(f"{path.relative_to(ROOT)}:{node.lineno} nominal_current")
        for k, s in enumerate(sides):
            other = sides[1 - k]
            if isinstance(s, ast.Constant) and s.value in (1000, 1000.0) and \
                    any(CURRENTISH.search(n) for n in _names(other)):
                out.append(f"{path.relative_to(ROOT)}:{node.lineno} ×/÷ 1000")
    return out


def test_the_conversion_finder_sees_each_form(tmp_path, monkeypatch):
    """The checker can fail: each form it must see, and a millisecond conversion it must not."""
    monkeypatch.setattr(f"{__name__}.ROOT", tmp_path)
    f = tmp_path / "m.py"
    f.write_text("a = c * lim.nominal_current\nb = i / nominal_current\nc = 1000.0 * currents\nd = ma / 1000\n"
                 "e = lim.resistance * lim.nominal_current ** 2\nf = watchdog_ms * 1000\n", encoding="utf-8")
    assert [s.split(":")[1].split()[0] for s in conversions(f)] == ["1", "2", "3", "4", "5"]


def test_an_ampere_changes_unit_only_in_electrics():
    """Per unit ↔ A ↔ mA (and the power and back-EMF factors built from ``nominal_current``) only in
    ``spherestep.electrics``."""
    found = [c for p in _sources() if p != ELECTRICS for c in conversions(p)]
    assert not found, "conversion outside spherestep.electrics: " + "; ".join(found)


@pytest.mark.parametrize("room", ["control", "magnetics", "hardware"])
def test_the_low_rooms_import_the_electrics_not_each_other(room):
    """DriveLimits comes from electrics in control, magnetics and hardware (not control.limits, which is gone)."""
    assert not (SRC / "control" / "limits.py").exists()
    uses = [(p, t) for p in (SRC / room).rglob("*.py") for t, _ in _imports(p) if t.endswith(".DriveLimits")]
    assert all(t == "spherestep.electrics.DriveLimits" for _, t in uses), uses


def test_every_current_link_is_a_link():
    """The serial link and the lockstep link both offer the one ``Link`` protocol (drive, read, off, info, a
    context manager), and the servo loop is typed by it, not by one of them."""
    import inspect

    from spherestep.hardware import DriveLink, Link, LockstepLink, run_servo

    members = ("drive", "read", "off", "__enter__", "__exit__")
    for cls in (DriveLink, LockstepLink):
        assert all(callable(getattr(cls, m, None)) for m in members), cls
    assert "Link" in str(inspect.signature(run_servo).parameters["link"].annotation)
    assert "DriveLink" not in str(inspect.signature(run_servo).parameters["link"].annotation)
    assert isinstance(Link, type)


def test_one_quaternion_order_in_every_file():
    """Files carry quaternions scalar first under the columns ``qw qx qy qz`` (``so3.quaternion_rows``), checked
    on a known rotation (a turn θ about z is ``(cos θ/2, 0, 0, sin θ/2)``), and no module but so3 converts a
    rotation to a quaternion by SciPy itself."""
    import math

    import numpy as np

    from spherestep import so3

    theta = 0.7
    q = so3.quaternion_rows(so3.exp(np.array([0.0, 0.0, theta])))
    assert np.allclose(q, [math.cos(theta / 2), 0.0, 0.0, math.sin(theta / 2)], atol=1e-15)
    assert so3.QUATERNION_COLUMNS == ("qw", "qx", "qy", "qz")
    found = [f"{p.relative_to(ROOT)}:{line}" for p in SRC.rglob("*.py") if p != SRC / "so3.py"
             for name, line in _calls(p) if name == "as_quat"]
    assert found == ["src/spherestep/magnetics/_ironforce.py:34"] or not found, found  # magpylib's, a count


def test_numba_lives_in_the_fast_path():
    """Only ``spherestep._fast`` imports numba (docs/conventions.md, the fast path)."""
    found = [f"{p.relative_to(ROOT)}:{line}" for p in SRC.rglob("*.py") if "_fast" not in p.parts
             for target, line in [(a.name, n.lineno) for n in ast.walk(_tree(p))
                                  if isinstance(n, ast.Import) for a in n.names]
             + [(n.module or "", n.lineno) for n in ast.walk(_tree(p))
                if isinstance(n, ast.ImportFrom)]
             if target.split(".")[0] == "numba"]
    assert not found, "numba imported outside spherestep._fast: " + "; ".join(found)


def test_the_selector_refuses_bad_input_and_builds_the_light_backends():
    """``drive.connect``: an unknown kind, a port kind without a port, an emulated kind without a plant and a relay
    kind without the plan's channel map are each one InputError naming the field; ``dry run`` is protocol 1's back
    end with the channels asked for, ``simulated`` the relay back end on the design's rotor at its start, each
    behind a ``RelayLink``."""
    import numpy as np

    from spherestep.commutation import default_channel_map
    from spherestep.drive import KINDS, connect
    from spherestep.errors import InputError
    from spherestep.hardware import Backend, Link, RelayLink
    from spherestep.magnetics import torque_map
    from spherestep.motor import prototype

    design = prototype()
    cmap = default_channel_map(len(design.stator))
    for kind, options, field in (("serial", {}, "kind"), ("port", {}, "port"), ("relay port", {}, "port"),
                                 ("port", {"port": "/dev/ttyACM0"}, "limits"), ("dry run", {}, "channel_map"),
                                 ("lockstep", {}, "plant"), ("simulated", {"plant": object(), "channel_map": cmap}, "R0")):
        with pytest.raises(InputError, match=f"^{field} must be"):
            with connect(design, kind, **options):
                pass
    assert set(KINDS) == {"port", "lockstep", "pty", "qemu", "relay port", "dry run", "simulated"}
    with connect(None, "dry run", channels=58, channel_map=cmap) as conn:
        assert isinstance(conn.link, RelayLink) and isinstance(conn.link.backend, Backend)
        assert conn.link.open().channels == 58 and conn.truth is None
    with connect(design, "simulated", plant=torque_map(design), R0=np.eye(3), channel_map=cmap) as conn:
        assert isinstance(conn.link, RelayLink) and conn.link.backend.coil_count == len(design.stator)
        assert np.array_equal(conn.link.backend.R, np.eye(3))
        assert conn.timing == {"clock": conn.link.clock, "sleep": conn.link.sleep}
    assert isinstance(conn.link, Link)


def test_every_kind_the_selector_builds_is_a_link():
    """Relay boards behind the one ``Link`` (issue 36): the relay adapter has every member of the protocol, and a
    relay link driven by amperes writes the relay masks of those coils (0 or ± the nominal current), refuses any
    other current naming the coil, and reads back what it drives."""
    import numpy as np

    from spherestep.commutation import default_channel_map
    from spherestep.electrics import DriveLimits
    from spherestep.errors import InputError
    from spherestep.hardware import DryRun, Link, RelayLink

    members = ("drive", "read", "off", "__enter__", "__exit__")
    assert all(callable(getattr(RelayLink, m, None)) for m in members)
    drive = DriveLimits(nominal_current=0.25, max_current=0.25)
    with RelayLink(DryRun(), default_channel_map(4), drive) as link:
        assert isinstance(link, Link)
        state = link.drive([0.25, 0.0, -0.25, 0.0])
        assert (link.backend.sent[-1].enable, link.backend.sent[-1].polarity) == (0b101, 1 << 6)
        assert np.array_equal(state.currents, [0.25, 0.0, -0.25, 0.0]) and state.field.shape == (0, 3)
        with pytest.raises(InputError, match="coil 1"):
            link.drive([0.25, 0.1, 0.0, 0.0])
    assert link.backend.sent[-1].enable == 0  # every relay open on leaving


def test_no_compiled_twins_on_controls_surface():
    """numba stays in the fast path (issue 36 §5): no function of the control room is a ``*_compiled`` twin or a
    ``_warm`` hook; the allocation's compiled entry points are ``_fast.allocation``'s (``solve_box``,
    ``solve_reachable``, ``warm``)."""
    found = [f"{p.relative_to(ROOT)}:{n.lineno} {n.name}" for p in (SRC / "control").rglob("*.py")
             for n in ast.walk(_tree(p))
             if isinstance(n, ast.FunctionDef) and (n.name.endswith("_compiled") or n.name.lstrip("_") == "warm")]
    assert not found, "compiled twins in control: " + "; ".join(found)
    from spherestep._fast import allocation

    assert all(callable(getattr(allocation, name)) for name in ("solve_box", "solve_reachable", "warm"))


MAX_LINES = 600


def test_no_module_over_600_lines():
    """Rooms of one concern (issue 36 §6): no module in src/ or scripts/ over :data:`MAX_LINES` lines."""
    long = {f"{p.relative_to(ROOT)}": n for p in _sources()
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > MAX_LINES}
    assert not long, f"over {MAX_LINES} lines (split by concept): {long}"


def test_the_top_level_lists_only_the_users_rooms():
    """The namespace advertises the rooms a user works with (``ROOMS``); every other top-level module is plumbing
    (``PLUMBING``: reachable by its path, not advertised), the private fast path or the command line."""
    import spherestep

    assert not set(spherestep.ROOMS) & set(spherestep.PLUMBING)
    assert set(rooms()) == set(spherestep.ROOMS) | set(spherestep.PLUMBING) | {"_fast", "cli"}
    assert spherestep.__all__ == list(spherestep.ROOMS) and not set(spherestep.PLUMBING) & set(dir(spherestep))
