"""docs/gallery.md's and README's tables from the gallery's ``metrics.csv``."""

from __future__ import annotations

import re
from .common import _thin, table


GALLERY_LABELS = {"prototype": "our reading of the paper", "jhu-as-built": "Johns Hopkins",
                  "ncsu-goldberg": "NCSU stator layout"}
GALLERY_TARGET = ("Kumagai & Hollis SIM (target)", *["n/a"] * 7, "target: 4 N·m about any axis", *["n/a"] * 3)


def _nm(x: float) -> str:
    return f"{x:.2f}" if x >= 1 else f"{x:.3f}"


def gallery_table(g: dict) -> str:
    """docs/gallery.md: the stored metrics of every entry (``src/spherestep/data/gallery/metrics.csv``)."""
    rows = []
    for key, r in g.items():
        label = GALLERY_LABELS.get(key)
        name = f"**{key}**" + (f" ({label}, {r['rotor_poles']}/{r['coils']})" if label else "")
        detent = f"{r['bias_torque_max_N_m']:.1f} N·m" if r["bias_torque_max_N_m"] else "0"
        mass = r["magnet_mass_kg"]
        rows.append((name, f"{r['rotor_poles']} / {r['coils']}", r["core"], _thin(r["states"]),
                     f"{r['resolution_median_deg']:.2f}°", f"{r['resolution_p95_deg']:.2f}°",
                     "yes" if r["reaches_all"] else "no", f"{100 * r['escape_violations'] / r['states']:.0f} %",
                     f"{_nm(r['torque_median_N_m'])} ({_nm(r['torque_p5_N_m'])}) N·m", detent,
                     f"{mass:.3g} kg" if mass < 1 else f"{mass:.2f} kg",
                     f"{r['coil_power_W']:.{1 if r['coil_power_W'] >= 1 else 2}f}"))
    rows.append(GALLERY_TARGET)
    return table(("design", "magnets / coils", "core", "states", "res. median", "res. p95", "all SO(3)", "escape",
                  "torque median (p5)", "detent", "magnets", "W/coil"), rows)


def gallery_drive_table(g: dict) -> str:
    """docs/gallery.md: each design driven (the servo's fastest turn, the settled relay plan), as stored."""
    rows = []
    for key, r in g.items():
        if r["servo_turn_s"] is None:
            servo = ("— (planner refused)", "—", "—", "—")
        else:
            servo = (f"{r['servo_turn_s']:.3f} s", f"{r['servo_final_error_deg']:.1e}°",
                     f"{r['servo_max_tracking_error_deg']:.2f}°", f"{r['servo_mean_power_W']:.1f} W")
        rows.append((f"**{key}**", *servo, "yes" if r["relay_executed"] else "no",
                     f"{r['relay_steps_on_plan']} / {r['relay_steps']}"))
    return table(("design", "servo time", "final", "max track", "power", "relay plan: executed", "steps on plan"), rows)


def gallery_asbuilt(g: dict) -> str:
    """docs/gallery.md: the as-built layout against our reading, in numbers."""
    p, j = g["prototype"], g["jhu-as-built"]
    return (f"{_thin(j['states'])} states against {_thin(p['states'])}, resolution median {j['resolution_median_deg']:.2f}° "
            f"against {p['resolution_median_deg']:.2f}°, torque in every direction median "
            f"{_nm(j['torque_median_N_m'])} against {_nm(p['torque_median_N_m'])} N·m and 5th percentile "
            f"{_nm(j['torque_p5_N_m'])} against {_nm(p['torque_p5_N_m'])} N·m")


def gallery_escape(g: dict) -> str:
    p = g["prototype"]
    return f"{100 * p['escape_violations'] / p['states']:.0f} %"


def gallery_gimbal(g: dict) -> str:
    return f"about {1e3 * g['gimbal-40mm']['torque_median_N_m']:.0f} mN·m"


def gallery_servo(g: dict) -> str:
    """docs/gallery.md: the servo's turn on each design, and where the planner refused, its reason."""
    arrived = {k: r for k, r in g.items() if r["servo_turn_s"] is not None}
    refused = {k: r for k, r in g.items() if r["servo_turn_s"] is None}
    out = "; ".join(f"{k} in {r['servo_turn_s']:.2f} s at {r['servo_mean_power_W']:.0f} W (tracked within "
                    f"{r['servo_max_tracking_error_deg']:.2f}°)" for k, r in arrived.items())
    if refused:
        reasons = []
        for k, r in refused.items():
            m = re.search(r"instead received '([^']*)'", r["drive_note"] or "")
            reasons.append(f"{k} ({m.group(1) if m else r['drive_note'] or 'no reason stored'})")
        out += ". The planner refuses the turn for " + "; ".join(reasons)
    return out


def gallery_relay(g: dict) -> str:
    """docs/gallery.md: the settled relay plan on each design, as stored."""
    done = [k for k, r in g.items() if r["relay_executed"]]
    part = ", ".join(f"{k} {r['relay_steps_on_plan']} of {r['relay_steps']}" for k, r in g.items()
                     if not r["relay_executed"])
    return (f"runs the whole turn on {', '.join(done) or 'none of the designs'}; steps settled within 0.5° of the "
            f"plan elsewhere: {part}")
