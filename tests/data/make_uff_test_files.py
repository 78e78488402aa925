"""Write the small Universal Files in tests/data/uff/ (python tests/data/make_uff_test_files.py).

Each file exercises one variant that real writers produce; the values are
simple closed forms so that tests can check the numbers read:

* every FRF record k holds H_k(f) = (k + 1) * (1 + 0.5j) * (1 + f / 100)
  in the units its header declares (:func:`truth`);
* the abscissa is 0, 2, 4, ... Hz (N_LINES lines) unless stated.

The headers are written here by hand, following the dataset 58 / 58b
specification (not by pyuff), so that layout details (padding, CRLF,
byte order, unit labels) are under our control.
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np

OUT = Path(__file__).resolve().parent / "uff"
N_LINES = 40
DF_HZ = 2.0


def truth(k: int, freq_hz: np.ndarray) -> np.ndarray:
    """The values (in file units) of FRF record k (0-based)."""
    return (k + 1) * (1 + 0.5j) * (1 + freq_hz / 100)


def delim(pad: bool) -> str:
    return f"{'-1':>6}" + (" " * 74 if pad else "")


def header58(
    *,
    rsp: tuple[int, int],
    ref: tuple[int, int],
    n: int,
    ord_type: int = 5,
    uniform: bool = True,
    x0: float = 0.0,
    dx: float = DF_HZ,
    num: tuple[int, int, int, str] = (12, 1, 0, "NONE"),
    den: tuple[int, int, int, str] = (13, 0, 1, "NONE"),
    func_type: int = 4,
    id1: str = "NONE",
    z_axis_value: str = "  0.00000e+00",
    rsp_name: str = "NONE",
) -> list[str]:
    """Records 1-11 of dataset 58 (list of lines)."""
    ids = [id1, "NONE", "01-Jan-25 00:00:00", "NONE", "NONE"]
    r6 = (f"{func_type:5d}{1:10d}{0:5d}{0:10d} {rsp_name:<10s}{rsp[0]:10d}{rsp[1]:4d}"
          f" {'NONE':<10s}{ref[0]:10d}{ref[1]:4d}")
    r7 = (f"{ord_type:10d}{n:10d}{int(uniform):10d}"
          f"{x0 if uniform else 0.0:13.5e}{dx if uniform else 0.0:13.5e}{z_axis_value}")

    def axis(t: int, le: int, fe: int, units: str, label: str = "NONE") -> str:
        return f"{t:10d}{le:5d}{fe:5d}{0:5d} {label:<20s} {units:<20s}"

    return [
        *ids,
        r6,
        r7,
        axis(18, 0, 0, "Hz", "Frequency"),
        axis(num[0], num[1], num[2], num[3], "Response"),
        axis(den[0], den[1], den[2], den[3], "Force"),
        axis(0, 0, 0, "NONE"),
    ]


def ascii_values(values: np.ndarray, per_line: int, width: int, pad_last: bool) -> list[str]:
    vals = list(values)
    if pad_last and len(vals) % per_line:
        vals += [0.0] * (per_line - len(vals) % per_line)  # padding values
    prec = 5 if width == 13 else 12
    return ["".join(f"{v:{width}.{prec}e}" for v in vals[i : i + per_line])
            for i in range(0, len(vals), per_line)]


def ascii58(data: np.ndarray, *, pad: bool = False, pad_last: bool = False,
            freq: np.ndarray | None = None, **kw: object) -> list[str]:
    """A complex single-precision dataset 58 (even, or uneven when ``freq``)."""
    n = data.size
    if freq is None:
        flat = np.column_stack([data.real, data.imag]).ravel()
        head = header58(n=n, **kw)  # type: ignore[arg-type]
    else:
        flat = np.column_stack([freq, data.real, data.imag]).ravel()
        head = header58(n=n, uniform=False, **kw)  # type: ignore[arg-type]
    return [delim(pad), f"{58:>6}", *head, *ascii_values(flat, 6, 13, pad_last), delim(pad)]


def binary58(data: np.ndarray, *, little: bool, double: bool, **kw: object) -> bytes:
    """A complex dataset 58b, even abscissa, as bytes."""
    ord_type = 6 if double else 5
    flat = np.column_stack([data.real, data.imag]).ravel()
    fmt = ("<" if little else ">") + ("d" if double else "f") * flat.size
    block = struct.pack(fmt, *flat)
    head = header58(n=data.size, ord_type=ord_type, **kw)  # type: ignore[arg-type]
    first = (f"{58:>6}b{1 if little else 2:6d}{2:6d}{11:12d}{len(block):12d}"
             f"{0:6d}{0:6d}{0:12d}{0:12d}")
    text = "\n".join([delim(False), first, *head]) + "\n"
    return text.encode("ascii") + block + b"\n" + delim(False).encode() + b"\n"


def dataset164(code: int, description: str, length: float, force: float) -> list[str]:
    return [delim(False), f"{164:>6}", f"{code:10d}{description:<20s}{2:10d}",
            f"{length:25.17E}{force:25.17E}{1.0:25.17E}".replace("E", "D"),
            f"{273.15:25.17E}".replace("E", "D"), delim(False)]


def unrelated_datasets() -> list[str]:
    """Datasets 151, 15, 18, 82, 55, 2411 and 2412 as real files carry them."""
    return [
        delim(True), f"{151:>6}", "beam model", "test of skipped datasets", "Simcenter Testlab",
        "01-Jan-25 00:00:00", "NONE", delim(True),
        delim(False), f"{15:>6}",
        f"{3:10d}{0:10d}{0:10d}{1:10d}{0.1:13.5e}{0.0:13.5e}{0.0:13.5e}",
        f"{6:10d}{0:10d}{0:10d}{1:10d}{0.3:13.5e}{0.0:13.5e}{0.0:13.5e}", delim(False),
        delim(False), f"{18:>6}",
        f"{1:10d}{1:5d}{0:10d}{0:10d}{0:10d}", "global cs",
        " 0.00000e+00 0.00000e+00 0.00000e+00 1.00000e+00 0.00000e+00 0.00000e+00",
        " 0.00000e+00 1.00000e+00 0.00000e+00", delim(False),
        delim(False), f"{82:>6}", f"{1:10d}{2:10d}{1:10d}", "line", f"{3:10d}{6:10d}",
        delim(False),
        delim(False), f"{2411:>6}",
        f"{1:10d}{1:10d}{1:10d}{11:10d}", f"{0.1:25.16E}{0.0:25.16E}{0.0:25.16E}".replace("E", "D"),
        delim(False),
        delim(False), f"{2412:>6}", f"{1:10d}{11:10d}{1:10d}{1:10d}{7:10d}{2:10d}",
        f"{0:10d}{1:10d}{1:10d}", f"{3:10d}{6:10d}", delim(False),
        delim(False), f"{55:>6}", "mode 1", "NONE", "NONE", "NONE", "NONE",
        f"{1:10d}{2:10d}{2:10d}{8:10d}{5:10d}{3:10d}", f"{2:10d}{4:10d}{1:10d}{1:10d}",
        f"{10.0:13.5e}{1.0:13.5e}{0.01:13.5e}{0.0:13.5e}", f"{3:10d}",
        "".join(f"{v:13.5e}" for v in (0, 0, 0, 0, 1, 0)), delim(False),
    ]


def write_lines(name: str, lines: list[str], newline: str = "\n", encoding: str = "ascii") -> None:
    (OUT / name).write_bytes((newline.join(lines) + newline).encode(encoding))


def main() -> None:
    OUT.mkdir(exist_ok=True)
    f = np.arange(N_LINES) * DF_HZ
    h = [truth(k, f) for k in range(3)]

    # 1. Testlab style: 80-column padded delimiters, CRLF, padding values on the
    #    last data line (40 complex = 80 values: 13 full lines + 2 values), the
    #    unrelated datasets of a whole project file, "inf" in the unused Z-axis
    #    value, combined label on the numerator and none on the denominator.
    lines = unrelated_datasets()
    for k, node in enumerate((3, 6)):
        lines += ascii58(h[k], pad=True, pad_last=True, rsp=(node, 3), ref=(8, 3),
                         num=(12, 0, 0, "(m/s^2)/N"), den=(0, 0, 0, "NONE"),
                         z_axis_value="          inf")
    write_lines("testlab_crlf_padded.uff", lines, newline="\r\n")

    # 2. dataset 164 inch / pound-force, unit labels NONE: data in in/s^2 per lbf
    lines = dataset164(7, "IN: Inch (pound f)", 1 / 0.0254, 1 / 4.4482216152605)
    lines += ascii58(h[0], rsp=(3, 3), ref=(8, 3))
    write_lines("units_164_inch_lbf.unv", lines)
    # dataset 164 says inch/lbf but the labels say m/s^2 and N: the labels win
    lines = dataset164(7, "IN: Inch (pound f)", 1 / 0.0254, 1 / 4.4482216152605)
    lines += ascii58(h[0], rsp=(3, 3), ref=(8, 3), num=(12, 0, 0, "m/s^2"),
                     den=(13, 0, 0, "N"))
    write_lines("units_164_vs_label.unv", lines)

    # 3. combined accelerance labels, one record per label (response node k+1)
    labels = ["g/N", "(1/N)*(m/s^2)", "m/s^2/N", "m/s2/N", "m / s^2 / N", "in/s^2/lbf",
              "mm/s^2/kN", "m/s²/N"]
    lines = []
    for k, label in enumerate(labels):
        lines += ascii58(h[0], rsp=(k + 1, 3), ref=(20, 3), num=(12, 0, 0, label),
                         den=(13, 0, 0, "NONE"))
    write_lines("labels_accelerance.uff", lines, encoding="utf-8")
    # numerator and denominator labels apart; mobility and receptance
    lines = []
    for k, (num, den) in enumerate([("m/s", "N"), ("mm/s", "N"), ("in/s", "lbf"),
                                    ("(m/s)/N", "NONE")]):
        lines += ascii58(h[0], rsp=(k + 1, 3), ref=(20, 3), num=(11, 0, 0, num),
                         den=(13, 0, 0, den))
    write_lines("labels_mobility.uff", lines)
    lines = []
    for k, label in enumerate(["m/N", "mm/N", "um/N"]):
        lines += ascii58(h[0], rsp=(k + 1, 3), ref=(20, 3), num=(8, 0, 0, label),
                         den=(13, 0, 0, "NONE"))
    write_lines("labels_receptance.uff", lines)

    # 4. directions: a roving hammer whose response is written -Z in one record
    #    and +Z in the other, references at 2 +Z and 5 -Z
    lines = ascii58(h[0], rsp=(3, -3), ref=(2, 3)) + ascii58(h[1], rsp=(3, 3), ref=(5, -3))
    lines += ascii58(h[2], rsp=(4, -1), ref=(2, 3))
    lines += ascii58(h[0], rsp=(4, 1), ref=(5, -3))
    write_lines("directions.uff", lines)

    # 5. uneven abscissa (spacing flag 0), log-spaced lines
    fu = np.geomspace(1.0, 200.0, N_LINES)
    write_lines("nonuniform.uff", ascii58(truth(0, fu), freq=fu, rsp=(3, 3), ref=(8, 3)))

    # 6. binary 58b: little-endian float32 and big-endian float64, two records each,
    #    with a dataset 151 and 82 in between
    for name, little, double in (("binary_le_single.ufb", True, False),
                                 ("binary_be_double.uff", False, True)):
        blob = ("\n".join(unrelated_datasets()[:8]) + "\n").encode()
        for k, node in enumerate((3, 6)):
            blob += binary58(h[k], little=little, double=double, rsp=(node, 3), ref=(8, 3))
        (OUT / name).write_bytes(blob)

    # 7. too short for identification (10 lines), and a time-record file
    write_lines("short_10_lines.uff", ascii58(truth(0, f[:10]), rsp=(3, 3), ref=(8, 3)))
    t = np.arange(64) / 1024.0
    lines = ascii58(np.exp(-t * 50) + 0j, rsp=(3, 3), ref=(3, 3), func_type=1, dx=t[1],
                    num=(12, 0, 0, "m/s^2"), den=(0, 0, 0, "NONE"))
    write_lines("time_only.uff", lines)


if __name__ == "__main__":
    main()
