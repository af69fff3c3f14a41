"""The HTML report: one self-contained file that works offline (plotly.js inline, nothing fetched).

Sections: the motor in 3-D (rotor magnets coloured by polarity, stator coils as rings, the sphere); the
design, packing and design-metric tables; the resolution histogram (Park distance from uniformly random
orientations to the nearest stepper state); and, when given, the commutation plan as a table and as an
animation with a step slider, the energy map and the simulated trajectory.

The commutation animation shows each step in the Fig. 10 view (Sec. IV-B) beside a 3-D view. Fig. 10 view:
orthographic projection on the plane normal to the rotation axis, the axis out of the page (the frame of
:mod:`spherestep.fig10`, the geometry :func:`spherestep.plots.draw_step` draws too). Grey outlines are the
stator coils, tinted when energised (red +1, blue −1); filled small outlines are the rotor poles they hold
(red north-out, blue south-out), the hatched one is the next pole to be attracted; the black line is fixed
in the rotor and shows how far it has turned, the dotted one where it started. Plans longer than
:data:`MAX_FRAMES` steps are animated on evenly spaced steps (the table lists them all).
"""

from .figures import (MAX_FRAMES, capability_figure, commutation_figure, energy_figure, frame_steps, motor_figure,
                      resolution_distances, resolution_figure, servo_figure, trajectory_figure)
from .page import Section, build_report, design_tables, plan_table, write_report

__all__ = ["MAX_FRAMES", "Section", "build_report", "capability_figure", "commutation_figure", "design_tables",
           "energy_figure", "frame_steps", "motor_figure", "plan_table", "resolution_distances", "resolution_figure",
           "servo_figure", "trajectory_figure", "write_report"]
