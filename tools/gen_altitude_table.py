"""Generate ``shared/altitude_table.py``: the ISA pressure-altitude table used by ``shared/altitude.py``.

Usage (from the repository root):

    python tools/gen_altitude_table.py           # write shared/altitude_table.py
    python tools/gen_altitude_table.py --check   # exit 1 if the committed file differs
    python tools/gen_altitude_table.py --report  # error by pressure range, writes nothing

Model: International Standard Atmosphere (US Standard Atmosphere 1976 below 47 km): layers with
lapse -0.0065 K/m (0-11 km), 0 (11-20 km), +0.001 K/m (20-32 km), +0.0028 K/m (32-47 km);
g = 9.80665 m/s^2, R = 287.053 J/(kg K), T0 = 288.15 K, P0 = 101325 Pa. Altitudes are
geopotential metres (standard pressure altitude), MSL.

Table design (see docs/ALTITUDE.md):

- The range 1 kPa to 110 kPa is split into bands. Inside a band the nodes are evenly spaced by an
  integer step in Pa/16, so the segment index is one floor division. Band steps grow with pressure
  so that every band meets the local error target (linear-interpolation error scales as
  step^2 * h''(p) and h'' ~ H / p^2, so the ideal step is proportional to p).
- Node values are the exact ISA altitude shifted down by half the larger sag of the two adjacent
  segments, which centres the (one-signed) chord error around zero and halves its peak.
- The integer interpolation is then evaluated on every representable input (every Pa/16 from
  1 kPa to 110 kPa) against the float model; the measured maxima go into the generated header.
"""

import argparse
import math
import sys
from itertools import pairwise
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:  # run as a script: make the project's packages importable
    sys.path.insert(0, str(ROOT))
from desktop.io.pressure_altitude import interpolate_mm  # noqa: E402
from shared.physics import G0_MPS2 as G0  # noqa: E402

OUTPUT = ROOT / "shared" / "altitude_table.py"
REGEN_CMD = "python tools/gen_altitude_table.py"

# ISA constants (as in AltOS make-altitude-pa and the US Standard Atmosphere 1976); g is G0.
R_AIR = 287.053
T0_K = 288.15
P0_PA = 101325.0
# (base geopotential altitude m, lapse K/m) for each layer.
LAYERS = ((0.0, -0.0065), (11000.0, 0.0), (20000.0, 0.001), (32000.0, 0.0028))

# Domain, in Pa x 16 (the project's pressure_q4_pa unit).
Q4 = 16
P_MIN_Q4 = 1000 * Q4
P_MAX_Q4 = 110000 * Q4
# Interpolation error targets (half of the chord sag, before integer rounding), metres. Above
# SPLIT the target is tight; below SPLIT_LO it is loose; in between it ramps geometrically so that
# neighbouring segments never differ much in sag (the node-centring step relies on that).
SPLIT_Q4 = 30000 * Q4
SPLIT_LO_Q4 = 20000 * Q4
TARGET_HI_M = 0.003
TARGET_LO_M = 0.05
# Largest pressure ratio across one band: more bands waste fewer nodes but cost search steps.
BAND_RATIO = 1.25
# Node values are stored in mm with this many fractional bits (halves the node rounding error).
ALT_FRAC_BITS = 2
# MicroPython small-int limit on 32-bit boards: every intermediate must stay inside +-2**30.
SMALL_INT_LIMIT = 2**30


def _layer_bases():
    """(base altitude m, lapse K/m, base temperature K, base pressure Pa) for each layer."""
    bases = []
    t_k, p_pa = T0_K, P0_PA
    for k, (h_m, lapse) in enumerate(LAYERS):
        bases.append((h_m, lapse, t_k, p_pa))
        if k + 1 < len(LAYERS):
            dh = LAYERS[k + 1][0] - h_m
            t_top = t_k + lapse * dh
            if lapse:
                p_pa = p_pa * (t_top / t_k) ** (-G0 / (R_AIR * lapse))
            else:
                p_pa = p_pa * math.exp(-G0 * dh / (R_AIR * t_k))
            t_k = t_top
    return bases


LAYER_BASES = _layer_bases()


def _layer_index(p_pa):
    """Index of the ISA layer containing each pressure (the layer whose base pressure is >= p)."""
    base_p = np.array([b[3] for b in LAYER_BASES])
    # Pressures above P0 (below sea level) stay in the troposphere layer.
    return np.clip(np.searchsorted(-base_p, -np.asarray(p_pa, dtype=float), side="right") - 1,
                   0, len(LAYER_BASES) - 1)


def isa_altitude_m(p_pa):
    """ISA geopotential altitude (m) for pressure(s) in Pa, float64, vectorised."""
    p = np.asarray(p_pa, dtype=float)
    layer = _layer_index(p)
    h = np.empty_like(p)
    for k, (h_b, lapse, t_b, p_b) in enumerate(LAYER_BASES):
        m = layer == k
        if lapse:
            h[m] = h_b + (t_b / lapse) * ((p[m] / p_b) ** (-R_AIR * lapse / G0) - 1.0)
        else:
            h[m] = h_b + (R_AIR * t_b / G0) * np.log(p_b / p[m])
    return h


def isa_d2h_dp2(p_pa):
    """Second derivative of ISA altitude with respect to pressure, m/Pa^2.

    From dh/dp = -R T / (g p) and dT/dh = L: d2h/dp2 = R T (1 + L R / g) / (g p^2).
    """
    p = np.asarray(p_pa, dtype=float)
    layer = _layer_index(p)
    lapse = np.array([b[1] for b in LAYER_BASES])[layer]
    h_base = np.array([b[0] for b in LAYER_BASES])[layer]
    t_base = np.array([b[2] for b in LAYER_BASES])[layer]
    t_k = t_base + lapse * (isa_altitude_m(p) - h_base)
    return R_AIR * t_k * (1.0 + lapse * R_AIR / G0) / (G0 * p * p)


def target_m(p_q4):
    """Interpolation error target (m) at pressure p_q4 (Pa x 16)."""
    if p_q4 >= SPLIT_Q4:
        return TARGET_HI_M
    if p_q4 <= SPLIT_LO_Q4:
        return TARGET_LO_M
    # Geometric ramp between the two targets.
    x = math.log(SPLIT_Q4 / p_q4) / math.log(SPLIT_Q4 / SPLIT_LO_Q4)
    return TARGET_HI_M * (TARGET_LO_M / TARGET_HI_M) ** x


def _max_step_q4(p_q4):
    """Largest step (Pa x 16) whose centred chord error at p_q4 meets the target there.

    Chord sag over a step s is h'' s^2 / 8; centring halves it, so s = sqrt(16 target / h'').
    """
    d2_q4 = float(isa_d2h_dp2(p_q4 / Q4)) / (Q4 * Q4)
    return int(math.floor(math.sqrt(16.0 * target_m(p_q4) / d2_q4)))


def design_bands():
    """Return [(start_q4, step_q4, segments)] covering P_MIN_Q4 .. beyond P_MAX_Q4."""
    bands = []
    start = P_MIN_Q4
    while start <= P_MAX_Q4:
        top = int(start * BAND_RATIO)
        # The step must meet the target everywhere in the band: check both ends and the ramp's
        # corners (between them target and h'' are monotonic, so these are the only candidates).
        checks = [start, top] + [c for c in (SPLIT_LO_Q4, SPLIT_Q4) if start < c < top]
        step = min(_max_step_q4(c) for c in checks)
        n = max(1, (top - start) // step)
        if start + n * step > P_MAX_Q4:
            # Last band: just enough segments to end strictly above P_MAX_Q4, so the interpolation
            # at P_MAX_Q4 always has a right-hand node.
            n = (P_MAX_Q4 - start) // step + 1
        bands.append((start, step, n))
        start += n * step
    return bands


def node_pressures_q4(bands):
    """All node pressures (Pa x 16), ascending, shared nodes at band joins counted once."""
    nodes = [start + j * step for start, step, n in bands for j in range(n)]
    last_start, last_step, last_n = bands[-1]
    nodes.append(last_start + last_n * last_step)
    return np.array(nodes, dtype=np.int64)


def fit_nodes(nodes_q4):
    """Integer node altitudes (mm x 2**ALT_FRAC_BITS), centred on the chord error."""
    h_node = isa_altitude_m(nodes_q4 / Q4)
    # Sag of the chord over each segment, evaluated at every integer input inside it.
    q = np.arange(nodes_q4[0], nodes_q4[-1] + 1, dtype=np.int64)
    seg = np.searchsorted(nodes_q4, q, side="right") - 1
    seg = np.minimum(seg, len(nodes_q4) - 2)
    frac = (q - nodes_q4[seg]) / (nodes_q4[seg + 1] - nodes_q4[seg])
    chord = h_node[seg] + (h_node[seg + 1] - h_node[seg]) * frac
    sag_all = chord - isa_altitude_m(q / Q4)
    starts = np.searchsorted(q, nodes_q4[:-1])
    sag = np.maximum.reduceat(sag_all, starts)
    # The chord lies above the convex curve: shift each node down by half the larger adjacent sag.
    shift = np.zeros(len(nodes_q4))
    shift[:-1] = sag
    shift[1:] = np.maximum(shift[1:], sag)
    scaled = (h_node - shift / 2.0) * 1000.0 * (1 << ALT_FRAC_BITS)
    return np.round(scaled).astype(np.int64)


def build():
    """Design the table; return a dict with the arrays, bands and measured errors."""
    bands = design_bands()
    nodes_q4 = node_pressures_q4(bands)
    alt = fit_nodes(nodes_q4)
    band_start = [b[0] for b in bands]
    band_step = [b[1] for b in bands]
    band_node = [0]
    for _, _, n in bands[:-1]:
        band_node.append(band_node[-1] + n)
    table = {
        "bands": bands,
        "band_start": band_start,
        "band_step": band_step,
        "band_node": band_node,
        "alt": [int(a) for a in alt],
    }
    table.update(measure(table))
    return table


def evaluate_int(table, p_q4):
    """Vectorised twin of shared.altitude.pressure_to_alt_mm over an int64 array of inputs.

    Returns (alt_mm, largest |intermediate|).
    """
    return interpolate_mm(p_q4, table["alt"], table["band_start"], table["band_step"], table["band_node"],
                          P_MIN_Q4, P_MAX_Q4, ALT_FRAC_BITS, bound=True)


def measure(table):
    """Exhaustive error of the integer interpolation against the float ISA model."""
    p_q4 = np.arange(P_MIN_Q4, P_MAX_Q4 + 1, dtype=np.int64)
    out, biggest = evaluate_int(table, p_q4)
    err_mm = out - isa_altitude_m(p_q4 / Q4) * 1000.0
    hi = p_q4 >= SPLIT_Q4
    # Worst case of the intermediates over every segment and every fraction, not just the inputs.
    alt = np.array(table["alt"], dtype=np.int64)
    d_max = 0
    for b, (_start, step, n) in enumerate(table["bands"]):
        first = table["band_node"][b]
        d = np.abs(np.diff(alt[first:first + n + 1]))
        d_max = max(d_max, int(d.max()) * (step - 1) + (step << (ALT_FRAC_BITS - 1)))
    return {
        "err_hi_mm": float(np.abs(err_mm[hi]).max()),
        "err_lo_mm": float(np.abs(err_mm[~hi]).max()),
        "biggest_intermediate": max(biggest, d_max, int(np.abs(alt).max())),
    }


def _format_ints(name, values, per_line=10):
    # A list literal made a tuple at import, not a tuple literal: MicroPython's freezer (mpy-tool)
    # stores an int outside +-8191 inside a constant tuple as a long-int object, which allocates
    # in every use. The ints of a list literal are compiled as small ints.
    lines = [name + " = tuple(["]
    for k in range(0, len(values), per_line):
        lines.append("    " + ", ".join(str(v) for v in values[k:k + per_line]) + ",")
    lines.append("])")
    return "\n".join(lines)


def render(table):
    """Source text of shared/altitude_table.py."""
    q = 1 << ALT_FRAC_BITS
    n_nodes = len(table["alt"])
    n_ints = n_nodes + 3 * len(table["bands"])
    header = f'''"""ISA pressure-altitude table for shared/altitude.py.

GENERATED by tools/gen_altitude_table.py; do not edit by hand. Regenerate with:

    {REGEN_CMD}

and verify the committed copy with ``{REGEN_CMD} --check``.

Model: International Standard Atmosphere, layers 0-11 km (-6.5 K/km), 11-20 km (isothermal),
20-32 km (+1 K/km); g = {G0}, R = {R_AIR}, T0 = {T0_K} K, P0 = {P0_PA:.0f} Pa. Altitude is
geopotential (standard pressure altitude), MSL.

Units and binary points:
- P_MIN_Q4, P_MAX_Q4, BAND_START_Q4, BAND_STEP_Q4: pressure in Pa with 4 fractional bits (Pa x 16).
- ALT_Q{ALT_FRAC_BITS}_MM: altitude in mm with {ALT_FRAC_BITS} fractional bits (mm x {q}).

Layout: band b starts at BAND_START_Q4[b] and has nodes every BAND_STEP_Q4[b]; its first node is
ALT_Q{ALT_FRAC_BITS}_MM[BAND_NODE[b]] and it ends at the next band's start (the last band ends past
P_MAX_Q4). Nodes are the ISA altitude minus half the chord sag of the adjacent segments.
{len(table["bands"])} bands, {n_nodes} nodes, {n_ints} ints in all.

Measured max |error| of the integer interpolation (this tool's numpy twin of
shared.altitude.pressure_to_alt_mm; tests/shared/test_altitude.py checks the function itself) vs the float
ISA model, every input from 1 kPa to 110 kPa in steps of 1/16 Pa, final rounding to mm included:
- 30 kPa to 110 kPa: {table["err_hi_mm"]:.2f} mm
- 1 kPa to 30 kPa:   {table["err_lo_mm"]:.2f} mm
Largest |intermediate| over all segments and fractions: {table["biggest_intermediate"]}
(limit 2**30 = {SMALL_INT_LIMIT}).
"""

# fmt: off
# tuple([...]) so that frozen firmware keeps every value a small int (see _format_ints).
'''
    body = [
        f"P_MIN_Q4 = {P_MIN_Q4}",
        f"P_MAX_Q4 = {P_MAX_Q4}",
        _format_ints("BAND_START_Q4", table["band_start"]),
        _format_ints("BAND_STEP_Q4", table["band_step"]),
        _format_ints("BAND_NODE", table["band_node"]),
        _format_ints(f"ALT_Q{ALT_FRAC_BITS}_MM", table["alt"], per_line=8),
    ]
    return header + "\n".join(body) + "\n"


def generate():
    """Build the table and return (source text, table); raise ValueError if it is unusable."""
    table = build()
    if table["biggest_intermediate"] >= SMALL_INT_LIMIT:
        raise ValueError("an intermediate reaches %d >= 2**30" % table["biggest_intermediate"])
    # Strictly falling nodes make the rounded interpolation monotonic over every input.
    if any(a <= b for a, b in pairwise(table["alt"])):
        raise ValueError("node altitudes are not strictly decreasing")
    return render(table), table


def report(table):
    """Error breakdown by pressure range (exhaustive over every Pa/16 input), as text lines."""
    p_q4 = np.arange(P_MIN_Q4, P_MAX_Q4 + 1, dtype=np.int64)
    out, _ = evaluate_int(table, p_q4)
    err_mm = out - isa_altitude_m(p_q4 / Q4) * 1000.0
    nodes = node_pressures_q4(table["bands"])
    lines = ["range kPa      nodes  max|err| mm  mean|err| mm"]
    edges_kpa = (1, 5, 10, 20, 30, 50, 70, 90, 110)
    for lo, hi in pairwise(edges_kpa):
        m = (p_q4 >= lo * 1000 * Q4) & (p_q4 < hi * 1000 * Q4 + (hi == edges_kpa[-1]))
        n = int(((nodes >= lo * 1000 * Q4) & (nodes < hi * 1000 * Q4)).sum())
        lines.append("%3d - %3d   %6d  %11.2f  %12.2f"
                     % (lo, hi, n, np.abs(err_mm[m]).max(), np.abs(err_mm[m]).mean()))
    return lines


def _shown(path):
    try:
        return str(path.relative_to(ROOT))
    except ValueError:
        return str(path)


def main(argv=None, output=None):
    """Command-line entry point; ``output`` overrides the written/checked path (for tests)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true",
                        help="exit 1 if %s differs from what would be generated" % OUTPUT.name)
    parser.add_argument("--report", action="store_true",
                        help="print the error by pressure range; write nothing")
    args = parser.parse_args(argv)
    output = OUTPUT if output is None else Path(output)
    text, table = generate()
    if args.report:
        print("\n".join(report(table)))
        return 0
    if args.check:
        current = output.read_text() if output.exists() else ""
        if current != text:
            print("%s is stale: run %s" % (_shown(output), REGEN_CMD), file=sys.stderr)
            return 1
        print("%s is up to date" % _shown(output))
        return 0
    output.write_text(text)
    print("wrote %s: %d bands, %d nodes; max error %.2f mm (30-110 kPa), %.2f mm (1-30 kPa)"
          % (_shown(output), len(table["bands"]), len(table["alt"]), table["err_hi_mm"],
             table["err_lo_mm"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
