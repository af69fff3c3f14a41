"""The gallery's entries: published spherical motors rebuilt as design files, each with its source and what we
assumed where the source is silent; and published targets of machines of another kind (not PM steppers).

The design files live in the package (``spherestep/data/gallery/*.yaml``, written by
``scripts/gallery_designs.py``); our reading of the paper's prototype (``spherestep/data/prototype.yaml``)
comes first. Sources were looked up again for this table; docs/gallery.md quotes what each one gives.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from importlib import resources

from ..errors import bad_value

PAPER = ("G. S. Chirikjian and D. Stein, \"Kinematic Design and Commutation of a Spherical Stepper Motor\", "
         "IEEE/ASME Trans. Mechatronics 4(4):342-353, 1999")
GAZETTE = ("P. Sneiderman, \"Spherical Motor Allows Ball-Based 3-D Movement\", The Johns Hopkins Gazette 30(17), "
           "16 Jan 2001")


@dataclass(frozen=True)
class Entry:
    """A published (or reference) PM spherical stepper as a design file.

    ``key`` names it; ``file`` is its design file inside the package data (``spherestep/data``); ``source`` the
    citation and ``url`` where it can be read; ``reported`` what the source states (pairs of quantity and
    value, as the source gives them); ``assumptions`` what we chose where it is silent.
    """

    key: str
    title: str
    file: str
    source: str
    url: str
    reported: tuple[tuple[str, str], ...]
    assumptions: tuple[str, ...]

    @property
    def path(self):
        """The design file (an ``importlib.resources`` traversable inside ``spherestep.data``)."""
        return resources.files("spherestep.data").joinpath(self.file)

    def design(self):
        """The motor, loaded fresh from the design file (:meth:`spherestep.motor.MotorDesign.loads`)."""
        from ..motor import MotorDesign

        return MotorDesign.loads(self.path.read_text(encoding="utf-8"), source=self.file)

    def to_dict(self) -> dict:
        """JSON-ready: every field, ``reported`` as a mapping."""
        out = asdict(self)
        out["reported"] = dict(self.reported)
        out["assumptions"] = list(self.assumptions)
        return out


@dataclass(frozen=True)
class Target:
    """A published machine of another kind, kept as a target for a PM stepper to match (issue 29 §1 turns it into
    a specification): ``requirements`` are (quantity, value) pairs as the source reports them."""

    key: str
    title: str
    kind: str
    source: str
    url: str
    requirements: tuple[tuple[str, str], ...]
    note: str

    def to_dict(self) -> dict:
        """JSON-ready: every field, ``requirements`` as a mapping."""
        out = asdict(self)
        out["requirements"] = dict(self.requirements)
        return out


SAME_PARTS = ("magnets, coils and gap as our prototype reading (1-in x 0.5-in N42 magnets, the 2-in x 1.625-in "
              "pot-core iron coils on 24 V / 100 W, 0.005-in gap): the iron model reuses the stored FEM pair table")

ENTRIES: tuple[Entry, ...] = (
    Entry(
        key="prototype",
        title="Chirikjian & Stein prototype, our reading of the paper (92/29)",
        file="prototype.yaml",
        source=f"{PAPER}, Sec. II-B-3 and IV",
        url="https://doi.org/10.1109/3516.809513",
        reported=(("sphere", "12-in plastic sphere"), ("coils", "2-in x 1.625-in electromagnets, soft iron"),
                  ("gap", "about 0.005 in"), ("supply", "24 V, up to 100 W"), ("relays", "up to 32 channels")),
        assumptions=("rotor: the truncated icosahedron refined once, 60 + 20 + 12 = 92 poles (Sec. II-B-3's "
                     "icosahedral packing with circles at the triangle centres and vertices)",
                     "stator: the truncated cuboctahedron refined once, the caps within 80 deg that fit a coil: 29",
                     "magnets: 1-in x 0.5-in N42 cylinders (the paper gives none)"),
    ),
    Entry(
        key="jhu-as-built",
        title="Chirikjian & Stein prototype as built at Johns Hopkins (80/16)",
        file="gallery/jhu-as-built.yaml",
        source=f"{GAZETTE}; {PAPER}",
        url="https://pages.jh.edu/~gazette/2001/jan1601/16sphere.html",
        reported=(("magnets", "80 permanent magnets inside a hollow sphere, in a precise pattern"),
                  ("coils", "a saddle of 16 circular electromagnets; two or more energised per step"),
                  ("sphere", "12-in diameter (the paper, Sec. IV-A)")),
        assumptions=("rotor: the paper's icosahedral packing (truncated icosahedron, 60) with its 20 hexagonal holes "
                     "filled and its 12 pentagonal holes empty: 80 poles (our 92-pole reading without the 12 "
                     "smallest); alternatives measured in docs/gallery.md",
                     "stator: the paper's octahedral packing (truncated cuboctahedron, 48 caps, unrefined), the two "
                     "rings of 8 about its four-fold axis within 60 deg: 16 coils",
                     f"parts: {SAME_PARTS}",
                     "polarity: the 60 primary poles north out, the 20 filled south out (no net dipole)"),
    ),
    Entry(
        key="ncsu-goldberg",
        title="NCSU PM spherical motor stator, Goldberg GP(3,0), 46 poles (layout only)",
        file="gallery/ncsu-goldberg.yaml",
        source=("J. A. Shah and G. D. Buckner, \"A Permanent Magnet Synchronous Spherical Motor for High-Mobility "
                "Servo-Actuation\", Machines 10(8):612, 2022; J. A. Shah, MS thesis, NC State University, 2020"),
        url="https://www.mdpi.com/2075-1702/10/8/612",
        reported=(("stator", "iron (1018 steel) poles on a Goldberg GP(3,0): 92 faces, 12 pentagons, 20 regular "
                             "and 60 irregular hexagons"),
                  ("poles used", "46 of 92, a hemisphere"), ("range", "+/-40 deg"),
                  ("pole gap", "2 mm between pole top plates")),
        assumptions=("layout: the truncated icosahedron refined once (92 caps, the same 60 + 20 + 12 orbits as "
                     "GP(3,0)'s faces); a design file cannot state Goldberg faces",
                     "the 46 poles: the caps within 85 deg of a five-fold axis (a pentagon at the centre)",
                     "rotor: the truncated cuboctahedron's 48 caps, all north out (the source's rotor is not "
                     "modelled: an octahedral packing against the icosahedral stator, Sec. II-B-3)",
                     f"parts: {SAME_PARTS}, not NCSU's pole plates and windings",
                     "a servo motor in the source; measured here as a stepper like the others"),
    ),
    Entry(
        key="dodecahedral-hobby",
        title="Dodecahedral hobby motor (antweight combat robots)",
        file="gallery/dodecahedral-hobby.yaml",
        source="F. Tavares, \"Spherical Motors\", felipetavares.com, 5 Jul 2025",
        url="https://felipetavares.com/post/spherical-motors",
        reported=(("purpose", "antweight (100-500 g) combat robots"),
                  ("sphere", "a dodecahedron of 12 printed pentagonal plates")),
        assumptions=("everything but the dodecahedral layout: the part of the post we could read gives no magnets, "
                     "coils or sizes",
                     "rotor: the dodecahedron's 20 caps (plate corners) with its 12 holes (plate centres) filled: "
                     "32 magnets, 10 x 5 mm N42",
                     "stator: 12 coils of the rhombicuboctahedron within 80 deg under a 60-mm ball",
                     "coils: air core (the source is silent), 20 x 12 mm, 0.3-mm wire, 12 V / 60 W"),
    ),
    Entry(
        key="gimbal-40mm",
        title="Gimbal-sized motor, 40-mm ball (the paper's construction scaled down)",
        file="gallery/gimbal-40mm.yaml",
        source=f"no published motor: {PAPER}, Sec. II-B-3 constructions at camera-gimbal size",
        url="",
        reported=(),
        assumptions=("rotor: the truncated icosahedron (60 caps, unrefined), 6 x 3 mm N42 magnets",
                     "stator: the truncated cuboctahedron (unrefined) within 80 deg: 24 coils",
                     "coils: air core (no source), 8 x 8 mm, 0.2-mm wire, 12 V / 20 W; 0.3-mm gap"),
    ),
)

TARGETS: tuple[Target, ...] = (
    Target(
        key="kumagai-hollis-sim",
        title="Kumagai & Hollis spherical induction motor (CMU)",
        kind="induction (copper over an iron spherical shell, 4 inductors); not a PM stepper",
        source=("M. Kumagai and R. L. Hollis, \"Development and Control of a Three DOF Spherical Induction "
                "Motor\", Proc. IEEE ICRA 2013, Karlsruhe, 6-10 May 2013 (abstract)"),
        url="",
        requirements=(("torque", "up to 4 N·m about any axis"), ("speed", "300 rpm continuous"),
                      ("range", "unlimited rotation")),
        note="a target for issue 29 §1 (a specification); no PM metrics apply",
    ),
)


def entries() -> tuple[Entry, ...]:
    """The gallery's design entries, our prototype reading first."""
    return ENTRIES


def targets() -> tuple[Target, ...]:
    """The published targets of machines of another kind."""
    return TARGETS


def entry(key: str) -> Entry:
    """The entry named ``key`` (InputError naming the known keys otherwise)."""
    for e in ENTRIES:
        if e.key == key:
            return e
    raise bad_value("entry", f"one of {', '.join(e.key for e in ENTRIES)}", key)
