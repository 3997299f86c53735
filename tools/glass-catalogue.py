#!/usr/bin/env python3
"""Writes lib/optics/glass_table.h, the glass catalogue that lib/optics/glass.c searches.

    python3 tools/glass-catalogue.py SPECS_DIR > lib/optics/glass_table.h
    python3 tools/glass-catalogue.py --markdown SPECS_DIR > docs/glasses.md

SPECS_DIR is database/data/specs in a checkout of the refractiveindex.info
database (github.com/polyanskiy/refractiveindex.info-database, public
domain, CC0), whose maker entries are the makers' own Zemax catalogues
(editions in MAKERS) with their dispersion coefficients and their nd, Vd.
The database's formulas (database/doc/Dispersion formulas.pdf), l in um:
  formula 2, "Sellmeier-2" (SCHOTT, OHARA, SUMITA, CDGM):
      n^2 - 1 = C1 + C2 l^2 / (l^2 - C3) + C4 l^2 / (l^2 - C5) + ...
      written here with C1 = 0: B1, C1, B2, C2, B3, C3;
  formula 3, "Polynomial" (HOYA, HIKARI):
      n^2 = C1 + C2 l^C3 + C4 l^C5 + ...
      HOYA's exponents are always 2, -2, -4, -6, -8: HOYA's own power
      series n^2 = A0 + A1 l^2 + A2 l^-2 + A3 l^-4 + A4 l^-6 + A5 l^-8
      (LR__GLASS_LAURENT); HIKARI uses those and others of 4, -10, -12
      (LR__GLASS_POWER, exponents in POWER_EXPONENTS).
Each row: name, maker, kind, nine coefficients (B1..B3, C1..C3 in um^2
and three zeros for LR__GLASS_SELLMEIER; A0..A5 and three zeros for
LR__GLASS_LAURENT; A0..A8 for LR__GLASS_POWER), nd, vd.
"""
import os
import sys

# The makers, in the order that settles a name two of them use (F2 is
# SCHOTT's, CDGM's and HIKARI's) when a lens file does not say whose:
# (directory in SPECS_DIR, maker, subdirectories read, the catalogue's
# edition as the database's entries cite it).  Every entry of those
# subdirectories is taken: a lens from a patent or a design program names
# any glass its maker sells.  SCHOTT's misc/ holds its fused silica
# (LITHOSIL-Q) and calcium fluoride (LITHOTEC-CAF2).
MAKERS = [
    ("schott", "SCHOTT", ["optical", "misc"], "2017-01-20b"),
    ("ohara", "OHARA", ["optical"], "2017-11-30"),
    ("hoya", "HOYA", ["optical"], "2017-04-01"),
    ("sumita", "SUMITA", ["optical"], "2017-02-02"),
    ("cdgm", "CDGM", ["optical"], "2022-06"),
    ("hikari", "HIKARI", ["optical"], "NIKON 2017-11"),
]

# The power series' exponents in every HOYA entry (formula 3), and in
# most of HIKARI's.
LAURENT_EXPONENTS = [2.0, -2.0, -4.0, -6.0, -8.0]
# The exponents of LR__GLASS_POWER, in the order of its A1..A8: every
# exponent that a HIKARI entry uses (its series add l^4, l^-10, l^-12).
POWER_EXPONENTS = [2.0, 4.0, -2.0, -4.0, -6.0, -8.0, -10.0, -12.0]


def read(path):
    """(kind, nine coefficients, nd, Vd) of one entry, or None when its
    first formula is none of the three forms above or it states no nd or
    Vd."""
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
    pad = [0.0] * 3
    if kind == "formula 2" and len(coef) == 7 and coef[0] == 0:
        # 0, B1, C1, B2, C2, B3, C3 -> B1, B2, B3, C1, C2, C3.
        return "LR__GLASS_SELLMEIER", coef[1::2] + coef[2::2] + pad, nd, vd
    if kind != "formula 3" or len(coef) % 2 != 1:
        return None
    if coef[2::2] == LAURENT_EXPONENTS:
        # A0, A1, 2, A2, -2, ... -> A0 .. A5.
        return "LR__GLASS_LAURENT", [coef[0]] + coef[1::2] + pad, nd, vd
    a = [coef[0]] + [0.0] * len(POWER_EXPONENTS)
    for c, e in zip(coef[1::2], coef[2::2]):
        k = 1 + POWER_EXPONENTS.index(e) if e in POWER_EXPONENTS else None
        if k is None or a[k]:
            return None
        a[k] = c
    return "LR__GLASS_POWER", a, nd, vd


def catalogue(specs):
    """Every glass of MAKERS as (name, MAKER, kind, coefficients, nd, vd),
    in MAKERS' order, each maker's by name."""
    rows, skipped = [], []
    for folder, maker, subdirs, _ in MAKERS:
        for sub in subdirs:
            d = os.path.join(specs, folder, sub)
            for f in sorted(os.listdir(d)):
                if not f.endswith(".yml"):
                    continue
                got = read(os.path.join(d, f))
                if got is None:
                    skipped.append("%s %s" % (maker, f[:-4]))
                    continue
                rows.append((f[:-4], maker) + got)
    if skipped:
        print("glass-catalogue: left out (no Sellmeier or power series, "
              "or no nd and Vd): %s" % ", ".join(skipped), file=sys.stderr)
    return rows


def markdown(rows):
    """docs/glasses.md: the catalogue, four glasses a row, by maker."""
    out = ["# The glass catalogue", "",
           "Generated by `tools/glass-catalogue.py --markdown` from the",
           "makers' Zemax catalogues in the refractiveindex.info database;",
           "how lenses name glasses: [lenses.md](lenses.md#glass).  Each",
           "glass with nd / vd as its maker states them.", ""]
    out += ["| maker | edition | glasses |", "|---|---|---|"]
    for _, maker, _, edition in MAKERS:
        out.append("| %s | %s | %d |" % (maker, edition,
                                        sum(r[1] == maker for r in rows)))
    out.append("")
    for _, maker, _, _ in MAKERS:
        cells = ["%s %.5f / %.2f" % (r[0], r[4], r[5])
                 for r in rows if r[1] == maker]
        out += ["## %s (%d)" % (maker, len(cells)), "",
                "| | | | |", "|---|---|---|---|"]
        cells += [""] * (-len(cells) % 4)
        for i in range(0, len(cells), 4):
            out.append("| " + " | ".join(cells[i:i + 4]) + " |")
        out.append("")
    return "\n".join(out).rstrip("\n")


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
    eds = ["%s %s" % (m[1], m[3]) for m in MAKERS]
    out = ["/* Generated by tools/glass-catalogue.py from the refractiveindex.info",
           " * database (public domain): the makers' Zemax catalogues,",
           " * %s," % ", ".join(eds[:3]),
           " * %s." % ", ".join(eds[3:]),
           " * Do not edit; run the script.  name, maker, kind, then nine",
           " * coefficients as the kind reads them (lib/optics/prescription.h), then",
           " * nd, vd as the maker states them. */"]
    for name, maker, kind, c, nd, vd in rows:
        out.append('{"%s", "%s", %s, {%s}, %r, %r},'
                   % (name, maker, kind, ", ".join(repr(x) for x in c),
                      nd, vd))
    print("\n".join(out))
    print("glass-catalogue: %d glasses" % len(rows), file=sys.stderr)


if __name__ == "__main__":
    main()
