#!/usr/bin/python3
"""Extracts the published data tables of the LOWTRAN 7 band model into CSV files.

LOWTRAN 7 (Kneizys et al. 1988, "Users guide to LOWTRAN 7", AFGL-TR-88-0177) is the US Air
Force's public band model; its molecular band-model parameters are those of Pierluissi &
Maragoudakis (1986, "Molecular transmission band models for LOWTRAN", AFGL-TR-86-0272) and its
water-vapour continuum that of Clough, Kneizys & Davies (1989, Atmos. Res. 23, 229-241). The
tables live in the DATA statements of the program's Fortran source; this script reads them
from a copy of that source (e.g. github.com/space-physics/lowtran, src/lowtran/fortran/
lowtran7.f) and writes:

  lowtran7_band_model.csv      wavenumber [cm-1] every 5 cm-1 and, per molecule, the band-model
                               coefficient C' (log10; -20 where the molecule has no band) and
                               the index of its band-model region
  lowtran7_band_regions.csv    per molecule and region: the exponent a of the transmittance
                               exp(-(W 10^C')^a) and the exponents n, m of the scaled absorber
                               amount W = u (P/P0)^n (T0/T)^m
  lowtran7_h2o_continuum.csv   wavenumber [cm-1] every 10 cm-1: self continuum at 296 K and
                               260 K and foreign continuum at 296 K [1e-20 cm^2 molec-1 (cm-1)-1]
  afgl_us_standard.csv         the AFGL US standard atmosphere (Anderson et al. 1986,
                               AFGL-TR-86-0110): altitude, pressure, temperature, H2O, O3

Usage: scripts/extract_lowtran7_tables.py LOWTRAN7.F OUTDIR
"""
import re
import sys


def statements(path):
    """Fixed-form Fortran: comment lines dropped, continuation lines joined."""
    return statements_from_text(open(path, encoding="latin-1").read())


def data_arrays(stmts):
    """name -> list of numbers, from 'DATA NAME/ v, v, n*v /' statements."""
    arrays = {}
    for s in stmts:
        for m in re.finditer(r"DATA\s+([A-Z0-9_]+)\s*/([^/]*)/", s.replace(" DATA", "DATA")):
            name, body = m.group(1), m.group(2)
            vals = []
            try:
                for tok in body.replace("\n", " ").split(","):
                    tok = tok.strip()
                    if not tok:
                        continue
                    if "*" in tok:
                        n, v = tok.split("*")
                        vals += [float(v.replace("D", "E"))] * int(n)
                    else:
                        vals.append(float(tok.replace("D", "E")))
            except ValueError:
                continue  # character data
            arrays.setdefault(name, vals)
    return arrays


def common(stmts, block):
    """The arrays of COMMON /block/ in order, with their sizes: of the statement that declares
    the most (the BLOCK DATA's own, not a routine's single-array view of it)."""
    best = None
    for s in stmts:
        m = re.search(r"COMMON\s*/\s*%s\s*/(.*?)(?:COMMON|$)" % block, s)
        if m:
            found = [(n, int(k)) for n, k in re.findall(r"([A-Z0-9]+)\s*\(\s*(\d+)\s*\)", m.group(1))]
            if best is None or len(found) > len(best):
                best = found
    if best is None:
        raise KeyError(block)
    return best


def concatenated(stmts, arrays, block, names=None):
    vals = []
    for name, size in common(stmts, block):
        if names and name not in names:
            continue
        v = arrays[name]
        assert len(v) == size, (block, name, len(v), size)
        vals += v
    return vals


def main(src, outdir):
    st = statements(src)
    arr = data_arrays(st)
    # Band-model intervals per molecule (BLOCK DATA WVBNRG) and the region each interval
    # belongs to (subroutine ABCDTA's wavenumber tests; regions numbered as LOWTRAN's W(17..)).
    def intervals(mol):
        lo = [int(v) for v in arr["IWL" + mol] if v != -999]
        hi = [int(v) for v in arr["IWH" + mol] if v != -999]
        return list(zip(lo, hi))
    region_of = {
        "H2O": lambda v: 17 + [i for i, (a, b) in enumerate(intervals("H2O")) if a <= v <= b][0],
        "O3": lambda v: 31 + [i for i, (a, b) in enumerate(intervals("O3")) if a <= v <= b][0],
        "CO2": lambda v: 36 + min(7, [i for i, (a, b) in enumerate(intervals("CO2")) if a <= v <= b][0]),
        "CH4": lambda v: 46,
        "N2O": lambda v: 47 if v <= 120 else (48 if v <= 2655 else 49),
        "O2": lambda v: 50 if v <= 265 else 51,
    }
    blocks = {"H2O": ("H2O", None), "O3": ("O3", None), "CO2": ("UFMIX1", None),
              "CH4": ("UFMIX2", ("C11CH4", "C12CH4", "C13CH4", "C14CH4")),
              "N2O": ("UFMIX2", ("C11N2O", "C21N2O", "C22N2O", "C23N2O", "C31N2O", "C32N2O", "C33N2O")),
              "O2": ("UFMIX2", ("C11O2", "C21O2", "C22O2", "C23O2"))}
    table = {}
    for mol, (block, names) in blocks.items():
        cp = concatenated(st, arr, block, names)
        ivs = intervals(mol)
        assert len(cp) == sum((b - a) // 5 + 1 for a, b in ivs), mol
        k = 0
        for a, b in ivs:
            for v in range(a, b + 1, 5):
                table.setdefault(v, {})[mol] = (cp[k], region_of[mol](v))
                k += 1
    mols = list(blocks)
    with open(f"{outdir}/lowtran7_band_model.csv", "w") as f:
        f.write("# LOWTRAN 7 molecular band model (Pierluissi & Maragoudakis 1986; Kneizys et al. 1988):\n")
        f.write("# per 5 cm-1 wavenumber, each molecule's coefficient C' (log10, -20: no band) and region.\n")
        f.write("# Extracted by scripts/extract_lowtran7_tables.py from the LOWTRAN 7 Fortran source.\n")
        f.write("# Columns: wavenumber [cm-1], then C' and region for " + ", ".join(mols) + ".\n")
        for v in range(0, 17905, 5):
            row = [str(v)]
            for m in mols:
                c, r = table.get(v, {}).get(m, (-20.0, 0))
                row += [f"{c:g}", str(r)]
            f.write(",".join(row) + "\n")
    # Region exponents: a from BLOCK DATA ABCD (by ABCDTA's band index), n and m from the
    # scaled densities DENSTY(k) = u PSS**n TSS**m of subroutine CONVRT.
    nm = {}
    for s in st:
        m = re.match(r"\s*DENSTY\((\d+),I\)=CON\w+\s*\*PSS\*\*([-\d.]+)\*TSS\*\*\(\s*([-\d.]+)\)", s)
        if m:
            nm[int(m.group(1))] = (float(m.group(2)), float(m.group(3)))
    a_of = {**{17 + i: arr["AH2O"][i] for i in range(14)}, **{31 + i: arr["AO3"][i] for i in range(5)},
            **{36 + i: arr["ACO2"][i] for i in range(8)}, 46: arr["ACH4"][0],
            **{47 + i: arr["AN2O"][i] for i in range(3)}, **{50 + i: arr["AO2"][i] for i in range(2)}}
    with open(f"{outdir}/lowtran7_band_regions.csv", "w") as f:
        f.write("# LOWTRAN 7 band-model regions: transmittance exp(-(W 10^C')^a), W = u (P/P0)^n (T0/T)^m,\n")
        f.write("# P0 = 1013.25 hPa, T0 = 273.15 K (Pierluissi & Maragoudakis 1986; Kneizys et al. 1988).\n")
        f.write("# Columns: region, a, n, m.\n")
        for r in sorted(a_of):
            f.write(f"{r},{a_of[r]:g},{nm[r][0]:g},{nm[r][1]:g}\n")
    # Water-vapour continuum (BLOCK DATA SF296, SF260, BFH2O): V1 = -20, DV = 10, 2003 points.
    # The three blocks share array names (S0000...); read them block by block from the source.
    text = open(src, encoding="latin-1").read()
    def block_values(start, end):
        sub = text[text.index(start):text.index(end)]
        vals = []
        for s in statements_from_text(sub):
            for m in re.finditer(r"DATA\s+([SF]\d{4})\s*/([^/]*)/", s):
                vals += [float(t) for t in m.group(2).split(",") if t.strip()]
        return vals
    s296 = block_values("BLOCK DATA SF296", "END BLOCKDATA SF296")
    s260 = block_values("BLOCK DATA SF260", "END BLOCKDATA SF260")
    f296 = block_values("BLOCK DATA BFH2O", "END BLOCKDATA BFH2O")
    assert len(s296) == len(s260) == len(f296) == 2003, (len(s296), len(s260), len(f296))
    with open(f"{outdir}/lowtran7_h2o_continuum.csv", "w") as f:
        f.write("# Water-vapour continuum of LOWTRAN 7 (Clough, Kneizys & Davies 1989, CKD): coefficients\n")
        f.write("# C~ [1e-20 cm^2 molec-1 (cm-1)-1] for self broadening at 296 K and 260 K and foreign at 296 K.\n")
        f.write("# Columns: wavenumber [cm-1], self 296 K, self 260 K, foreign 296 K.\n")
        for i in range(2, 2003):
            f.write(f"{-20 + 10 * i},{s296[i]:g},{s260[i]:g},{f296[i]:g}\n")
    # N2 collision-induced continuum (2080-2740 cm-1, 5 cm-1) and ozone's visible (Chappuis)
    # absorption (13000-24200 cm-1, 200 cm-1) of BLOCK DATA C4D.
    c4 = arr["C401"] + arr["C4115"]
    c8 = arr["C8"][:57]
    assert len(c4) == 133
    with open(f"{outdir}/lowtran7_n2_continuum.csv", "w") as f:
        f.write("# N2 collision-induced absorption of LOWTRAN 7 (Kneizys et al. 1988): coefficient per km of\n")
        f.write("# air at the amount 0.781 (P/P0)^2 (T0/T)^1.5.\n# Columns: wavenumber [cm-1], coefficient [km-1].\n")
        for i, v in enumerate(c4):
            f.write(f"{2080 + 5 * i},{v:g}\n")
    with open(f"{outdir}/lowtran7_o3_visible.csv", "w") as f:
        f.write("# Ozone's visible (Chappuis) absorption of LOWTRAN 7 (Kneizys et al. 1988).\n")
        f.write("# Columns: wavenumber [cm-1], coefficient [(atm-cm)-1].\n")
        for i, v in enumerate(c8):
            f.write(f"{13000 + 200 * i},{v:g}\n")
    # The AFGL US standard atmosphere: model 6 of BLOCK DATA MLATMB.
    alt, p, t = arr["ALT"], arr["P6"], arr["T6"]
    h2o, o3 = arr["AMOL61"], arr["AMOL63"]
    with open(f"{outdir}/afgl_us_standard.csv", "w") as f:
        f.write("# AFGL US standard atmosphere (Anderson et al. 1986, AFGL-TR-86-0110), as LOWTRAN 7 carries it.\n")
        f.write("# Columns: altitude [km], pressure [hPa], temperature [K], H2O [ppmv], O3 [ppmv].\n")
        for row in zip(alt, p, t, h2o, o3):
            f.write(",".join(f"{v:g}" for v in row) + "\n")


def statements_from_text(text):
    """statements() of a source's text."""
    out = []
    for line in text.split("\n"):
        if not line or line[0] in "Cc*!":
            continue
        if len(line) > 5 and line[5] not in " 0" and out:
            out[-1] += line[6:72]
        else:
            out.append(line[6:72])
    return out


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
