#!/usr/bin/env python3
"""Writes lib/glass_table.h, the glass catalogue that lib/glass.c searches.

    python3 tools/glass-catalogue.py SPECS_DIR > lib/glass_table.h
    python3 tools/glass-catalogue.py --markdown SPECS_DIR   (docs/lenses.md)

SPECS_DIR is database/data/specs in a checkout of the refractiveindex.info
database (github.com/polyanskiy/refractiveindex.info-database, public
domain, CC0), whose schott/, ohara/ and hoya/ entries are the makers' Zemax
catalogues (SCHOTT 2017-01-20b, OHARA 2017-11-30, HOYA 2017-04-01) with
their dispersion coefficients and their nd, Vd.  The database's formulas
(database/doc/Dispersion formulas.pdf), l in um:
  formula 2, "Sellmeier-2" (SCHOTT, OHARA):
      n^2 - 1 = C1 + C2 l^2 / (l^2 - C3) + C4 l^2 / (l^2 - C5) + ...
      written here with C1 = 0: B1, C1, B2, C2, B3, C3;
  formula 3, "Polynomial" (HOYA):
      n^2 = C1 + C2 l^C3 + C4 l^C5 + ...
      HOYA's exponents are always 2, -2, -4, -6, -8: HOYA's own power
      series n^2 = A0 + A1 l^2 + A2 l^-2 + A3 l^-4 + A4 l^-6 + A5 l^-8.
Each row: name, maker, kind, six coefficients (B1..B3, C1..C3 in um^2 for
LR__GLASS_SELLMEIER; A0..A5 for LR__GLASS_LAURENT), nd, vd.
"""
import os
import sys

# The classic glasses of camera lenses: Schott's crowns, flints, barium and
# lanthanum glasses, and their Ohara and Hoya counterparts.
GLASSES = {
    "schott": """N-BK7 N-BK10 N-K5 N-KF9 N-ZK7 N-FK5 N-FK51A N-PK51 N-PSK3
        N-PSK53A N-BAK1 N-BAK2 N-BAK4 N-BALF4 N-BALF5 N-BAF4 N-BAF10 N-BAF51
        N-BAF52 N-BASF2 N-BASF64 N-SK2 N-SK4 N-SK5 N-SK11 N-SK14 N-SK16
        N-SSK2 N-SSK5 N-SSK8 N-LAK7 N-LAK8 N-LAK9 N-LAK10 N-LAK12 N-LAK14
        N-LAK22 N-LAK33A N-LAF2 N-LAF21 N-LAF34 N-LASF9 N-LASF31A N-LASF40
        N-LASF44 N-KZFS4 N-KZFS8 F2 F5 LF5 LLF1 SF1 SF2 SF4 SF5 SF6 SF10
        SF11 N-F2 N-SF1 N-SF2 N-SF4 N-SF5 N-SF6 N-SF8 N-SF10 N-SF11 N-SF57
        N-SF66""",
    "ohara": """S-BSL7 S-BSM2 S-BSM16 S-BSM81 S-BAL11 S-BAL35 S-BAL42 S-BAM4
        S-BAH11 S-FSL5 S-FPL51 S-FPL53 S-LAL8 S-LAL14 S-LAL18 S-LAM2 S-LAM7
        S-LAH51 S-LAH53 S-LAH55V S-LAH58 S-LAH60 S-LAH64 S-LAH66 S-TIL1
        S-TIM2 S-TIM22 S-TIM28 S-TIH1 S-TIH6 S-TIH11 S-TIH53 S-NBH5 S-NPH1""",
    "hoya": """BSC7 E-C3 FC5 FCD1 FCD10A FCD100 PCD4 PCD51 BAC4 BACD2 BACD4
        BACD5 BACD11 BACD14 BACD15 BACD16 BACD18 BACED5 LAC7 LAC8 LAC10
        LAC12 LAC13 LAC14 TAC2 TAC4 TAC8 E-CF6 E-FEL1 E-FEL2 E-FL5 E-FL6
        E-F1 E-F2 E-F3 E-F5 E-F8 E-FD1 E-FD2 E-FD4 E-FD5 E-FD8 E-FD10
        E-FD13 E-FD15 E-FDS1 FD60 FD110 FD140 FF5 BAF10 BAF11 BAFD7 BAFD8
        E-BAF8 E-ADF10 LAF2 LAF3 E-LAF7 NBF1 NBFD3 NBFD10 NBFD11 NBFD12
        NBFD13 NBFD15 TAF1 TAF2 TAF3 TAF4 TAF5 TAFD5F TAFD25 TAFD30 FDS90""",
}

# The power series' exponents in every HOYA entry (formula 3).
LAURENT_EXPONENTS = [2.0, -2.0, -4.0, -6.0, -8.0]


def read(path):
    """(kind, six coefficients, nd, Vd) of one entry, or None when its
    first formula is neither of the two forms above."""
    coef = nd = vd = None
    kind = None
    with open(path, encoding="utf-8") as f:
        for line in f:
            s = line.strip()
            if s.startswith("- type:") and kind is None:
                kind = s.split(":", 1)[1].strip()
            elif s.startswith("coefficients:") and coef is None:
                coef = [float(x) for x in s.split(":", 1)[1].split()]
            elif s.startswith("nd:"):
                nd = float(s.split(":", 1)[1])
            elif s.startswith("Vd:"):
                vd = float(s.split(":", 1)[1])
    if coef is None or nd is None or vd is None:
        return None
    if kind == "formula 2" and len(coef) == 7 and coef[0] == 0:
        # 0, B1, C1, B2, C2, B3, C3 -> B1, B2, B3, C1, C2, C3.
        return "LR__GLASS_SELLMEIER", coef[1::2] + coef[2::2], nd, vd
    if kind == "formula 3" and len(coef) == 11 \
            and coef[2::2] == LAURENT_EXPONENTS:
        # A0, A1, 2, A2, -2, ... -> A0 .. A5.
        return "LR__GLASS_LAURENT", [coef[0]] + coef[1::2], nd, vd
    return None


def catalogue(specs):
    """Every glass of GLASSES as (name, MAKER, kind, coefficients, nd, vd)."""
    rows, seen = [], set()
    for maker, names in GLASSES.items():
        for name in names.split():
            got = read(os.path.join(specs, maker, "optical", name + ".yml"))
            if got is None:
                sys.exit("glass-catalogue: %s %s is neither Sellmeier nor "
                         "HOYA's power series" % (maker, name))
            # lr__glass_named matches names without regard to case.
            if name.upper() in seen:
                sys.exit("glass-catalogue: %s twice" % name)
            seen.add(name.upper())
            rows.append((name, maker.upper()) + got)
    return rows


def markdown(rows):
    """The catalogue tables of docs/lenses.md, four glasses a row."""
    out = []
    for maker in GLASSES:
        cells = ["%s %.5f / %.2f" % (r[0], r[4], r[5])
                 for r in rows if r[1] == maker.upper()]
        out += ["**%s** (%d)" % (maker.upper(), len(cells)), "",
                "| | | | |", "|---|---|---|---|"]
        cells += [""] * (-len(cells) % 4)
        for i in range(0, len(cells), 4):
            out.append("| " + " | ".join(cells[i:i + 4]) + " |")
        out.append("")
    return "\n".join(out)


def main():
    args = sys.argv[1:]
    as_markdown = args[:1] == ["--markdown"]
    if as_markdown:
        args = args[1:]
    if len(args) != 1:
        sys.exit(__doc__)
    rows = catalogue(args[0])
    if as_markdown:
        print(markdown(rows))
        return
    out = ["/* Generated by tools/glass-catalogue.py from the refractiveindex.info",
           " * database (public domain): the makers' Zemax catalogues, SCHOTT",
           " * 2017-01-20b, OHARA 2017-11-30 and HOYA 2017-04-01.  Do not edit;",
           " * run the script.  name, maker, kind, then B1..B3, C1..C3 (um^2) for",
           " * LR__GLASS_SELLMEIER or A0..A5 for LR__GLASS_LAURENT (HOYA's power",
           " * series), then nd, vd as the maker states them. */"]
    for name, maker, kind, c, nd, vd in rows:
        out.append('{"%s", "%s", %s, {%s}, %r, %r},'
                   % (name, maker, kind, ", ".join(repr(x) for x in c),
                      nd, vd))
    print("\n".join(out))
    print("glass-catalogue: %d glasses" % len(rows), file=sys.stderr)


if __name__ == "__main__":
    main()
