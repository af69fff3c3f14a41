"""Design files: a :class:`~spherestep.motor.MotorDesign` as a versioned YAML (or TOML) document.

Schema version 2 (version 1 lacks ``coil`` and is still read) is described field by field in
``docs/design-files.md``. In short::

    schema_version: 2
    name: prototype
    rotor:   {packing: truncated-icosahedron, refine: 1, polarity: {primary: +1, filled: -1}}
    stator:  {packing: truncated-cuboctahedron, refine: 1, axis: [0, 0, -1], cap_half_angle: 80 deg, coils: fit}
    dimensions: {sphere_diameter: 12 in, magnet_diameter: 1 in, magnet_length: 0.5 in,
                 coil_diameter: 2 in, coil_length: 1.625 in, air_gap: 0.005 in}
    coil:    {core: iron, wire_diameter: 286 um, fill_factor: 0.6, supply_voltage: 24 V, supply_power: 100 W}

Every length and angle carries its unit (``"12 in"``, ``"25.4 mm"``, ``"80 deg"``, ``"1.4 rad"``), converted once
to metres and radians (:mod:`.quantities`). The way in is the motor: ``MotorDesign.load(path)`` /
``MotorDesign.loads(text)`` read (:mod:`.load`: syntax, :mod:`.schema`, then ``MotorDesign.from_packings``),
``design.save(path)`` / ``design.dumps()`` write (:mod:`.dump`); ``save`` then ``load`` gives back the same
design (centres to 1e-12, everything else exactly). Every mistake raises :class:`DesignFileError` (an
:class:`~spherestep.errors.InputError`) whose one-line message names the file, the field path such as
``stator.cap_half_angle`` (also as data, ``exc.field``), and the fix.

Imports run one way: quantities → schema → load → dump; this package never imports :mod:`spherestep.motor`
(the motor imports it, and hands its class to :func:`build`).
"""

from .dump import dumps, save, to_dict
from .load import FILE_FIELDS, Document, build, file_field, parse, prototype_text, read, read_text, validate
from .quantities import angle_text, length_text, tesla_text
from .schema import MAX_REFINE, SCHEMA_VERSION, DesignFileError, DesignSpec

__all__ = ["FILE_FIELDS", "MAX_REFINE", "SCHEMA_VERSION", "DesignFileError", "DesignSpec", "Document",
           "angle_text", "build", "dumps", "file_field", "length_text", "parse", "prototype_text", "read",
           "read_text", "save", "tesla_text", "to_dict", "validate"]
