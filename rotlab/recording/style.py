"""One colour language and one label rule for every recording rotlab writes.

Colours
    x, y, z components (and p, q, r, the body components of ω) are red, green, blue — in the 3D
    view (body axes) and in every plot.  The energy series T, V, T + V, W, T + V − W take five
    hues far apart on the colour wheel.  Vectors drawn in 3D keep the colour of their plot
    (ω orange, L violet, loads magenta, the field grey).
Labels
    A 3D label is a short symbol (at most ``MAX_3D_LABEL`` characters: "ω", "L", "x", "M1"); the
    magnitudes and scale factors live in the plots and the run panel.  Every label and series name
    uses only glyphs of the viewer's font (Inter: Latin, Greek, digits, common punctuation and
    sub/superscript digits) — the viewer panics on a missing glyph such as "⊥".
"""

from __future__ import annotations

import colorsys
import unicodedata

Color = tuple[int, int, int]

X_RED: Color = (230, 70, 70)
Y_GREEN: Color = (80, 190, 80)
Z_BLUE: Color = (70, 130, 245)
XYZ: list[Color] = [X_RED, Y_GREEN, Z_BLUE]

OMEGA: Color = (255, 160, 30)  # ω: arrow, herpolhode, polhode
L: Color = (175, 100, 245)  # L: arrow
LOAD: Color = (240, 80, 200)  # applied loads
FIELD: Color = (160, 160, 160)  # the uniform field g
AXIS_TRACE: Color = (90, 215, 230)  # the reference-axis tip (symmetry axis, else spin axis)
BODY: Color = (200, 170, 90)
ARM: Color = (40, 40, 40)
ROTOR: Color = (120, 200, 120)  # a gyrostat's wheels

ENERGY: dict[str, Color] = {
    "T": (255, 140, 20),  # kinetic: orange
    "V": (60, 200, 210),  # potential: teal
    "T+V": (235, 235, 235),  # mechanical total: white
    "W": (240, 80, 200),  # work of non-conservative loads: magenta
    "T+V−W": (240, 240, 80),  # the invariant H = T + V − W: yellow
}

# invariant drifts: distinct hues, none of them red/green/blue (those mean components)
INVARIANT: dict[str, Color] = {
    "energy": (240, 240, 80),
    "quaternion_norm": (160, 160, 160),
    "L_norm": (175, 100, 245),
    "L_space": (255, 160, 30),
    "L_vertical": (60, 200, 210),
    "L_symmetry": (240, 80, 200),
}

# one hue per series where several are not components (not red/green/blue, which mean x, y, z): the values an
# event records, the driven rotors
HUES: list[Color] = [(255, 160, 30), (175, 100, 245), (60, 200, 210), (240, 240, 80), (240, 80, 200), (235, 235, 235)]
SECTION: Color = (90, 215, 230)  # the points of a Poincaré section
POLHODE: Color = (150, 100, 40)  # the phase portrait's family of polhodes (ω's orange, dimmed)
SEPARATRIX: Color = (230, 70, 70)  # the separatrices and the unstable equilibria

MAX_3D_LABEL = 3

_SAFE_EXTRA = set("·×−–—±≤≥≈°′″ₓᵧ₀₁₂₃₄₅₆₇₈₉⁰¹²³⁴⁵⁶⁷⁸⁹₋⁻ψθφωΛΔΩ…²³|")


def glyph_ok(ch: str) -> bool:
    """True for characters the viewer's font draws: printable ASCII, Latin-1 letters, Greek,
    and the handful of symbols in ``_SAFE_EXTRA``."""
    if ch in _SAFE_EXTRA or 0x20 <= ord(ch) < 0x7F:
        return True
    name = unicodedata.name(ch, "")
    return name.startswith(("GREEK SMALL LETTER", "GREEK CAPITAL LETTER", "LATIN SMALL LETTER", "LATIN CAPITAL LETTER")) and ord(ch) < 0x250


def check_text(text: str) -> str:
    """``text`` if every glyph is drawable; ValueError naming the first one that is not."""
    for ch in text:
        if not glyph_ok(ch):
            raise ValueError(f"{text!r}: the viewer's font has no glyph for {ch!r} (U+{ord(ch):04X})")
    return text


def drawable(text: str) -> str:
    """``text`` with every glyph the viewer's font lacks replaced by "?" (user-given names)."""
    return "".join(ch if glyph_ok(ch) else "?" for ch in text)


def label_3d(text: str) -> str:
    """A 3D label: a short symbol with drawable glyphs."""
    if len(text) > MAX_3D_LABEL:
        raise ValueError(f"3D label {text!r} is longer than {MAX_3D_LABEL} characters: put it in a plot or the run panel")
    return check_text(text)


def ramp(n: int) -> list[Color]:
    """``n`` colours from violet through teal to yellow: case k of a sweep sorted by its parameter
    gets ramp(n)[k] (``ramp_color(k / (n − 1))``)."""
    return [ramp_color(k / max(n - 1, 1)) for k in range(n)]


def ramp_color(s: float) -> Color:
    """The colour at ``s`` ∈ [0, 1] from violet (0) through teal to yellow (1), viridis-like and
    light enough on a dark background."""
    h = 0.78 - 0.62 * s  # violet 0.78 → yellow 0.16
    r, g, b = colorsys.hls_to_rgb(h, 0.45 + 0.2 * s, 0.85)
    return (round(255 * r), round(255 * g), round(255 * b))
