"""The paper's numbers, kept exactly as the paper prints them.

A report quotes the paper's values verbatim (its digits and units: "1376 bytes", never
"1.38e+03"; "9.60 MB", never "9.6 MB") in its markdown and in its CSV data, where the
``paper`` column holds the quotation as text. Our own numbers may be rounded; the paper's
never are. :attr:`PaperValue.value` is the number a ratio is computed from.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from replication.errors import InputError

__all__ = [
    "PaperStatement",
    "PaperValue",
    "PAPER_TABLE1",
    "PAPER_TABLE1_STATEMENTS",
    "PAPER_CASESTUDY",
    "all_paper_values",
]

_NUMBER = re.compile(r"-?\d+(?:\.\d+)?")


@dataclass(frozen=True)
class PaperValue:
    """One value stated by the paper.

    Attributes
    ----------
    quote : str
        The value exactly as the paper prints it, with its unit ("306 bytes", "0.0038 s",
        "almost half").
    value : float
        The number it stands for (ratios are computed from it); for a worded value such as
        "almost half" it is stated explicitly (0.5).
    where : str
        Where the paper says it.
    """

    quote: str
    value: float
    where: str

    def __post_init__(self) -> None:
        if not self.quote or self.quote != self.quote.strip():
            raise InputError(f"a paper quotation must be text without outer spaces, got {self.quote!r}")
        if not math.isfinite(self.value):
            raise InputError(f"a paper value must be finite, got {self.value!r} for {self.quote!r}")
        digits = _NUMBER.match(self.quote)
        if digits and float(digits.group()) != self.value:
            raise InputError(f"paper value {self.value!r} does not match its quotation {self.quote!r}")

    def __str__(self) -> str:
        return self.quote

    def __float__(self) -> float:
        return self.value


@dataclass(frozen=True)
class PaperStatement:
    """A claim the paper makes in words, without a number to compare with ("the difference
    grows ..."): quoted verbatim beside the verdict on it, with no ratio.

    Attributes
    ----------
    quote : str
        The paper's words exactly.
    where : str
        Where the paper says it.
    """

    quote: str
    where: str

    def __post_init__(self) -> None:
        if not self.quote or self.quote != self.quote.strip():
            raise InputError(f"a paper quotation must be text without outer spaces, got {self.quote!r}")

    def __str__(self) -> str:
        return self.quote


def _v(quote: str, where: str, value: float | None = None) -> PaperValue:
    if value is None:
        value = float(quote.split()[0])
    return PaperValue(quote, value, where)


#: Table 1 and its discussion (section 4 text, section 5 items 1-2).
PAPER_TABLE1: dict[str, PaperValue] = {
    "adt_bytes_9": _v("306 bytes", "section 4"),
    "nurbs_bytes_9": _v("1376 bytes", "section 4"),
    "adt_s_9": _v("0.0038 s", "section 4"),
    "nurbs_s_9": _v("0.018 s", "section 4"),
    "size_difference_200": _v("5912 bytes", "section 5, item 1"),
    "time_difference_200": _v("0.0129 s", "section 5, item 2"),
    "size_ratio": _v("almost half", "section 5, item 1", 0.5),
    "speed_ratio": _v("almost 3 times faster", "section 5, item 2", 3.0),
    "deviation_pct": _v("under 5%", "section 4", 5.0),
}

#: Table 1's worded claims (section 4), beside the trend and similarity verdicts.
PAPER_TABLE1_STATEMENTS: dict[str, PaperStatement] = {
    "difference_grows": PaperStatement(
        "the difference grows with the increase in the number of points", "section 4"
    ),
    "similar": PaperStatement(
        "It can be concluded with 95% confidence that surfaces generated from ADT and NURBS are similar",
        "section 4",
    ),
    "under_5_statistically": PaperStatement("the deviation is still under 5% statistically", "section 4"),
    "deviation_reduced": PaperStatement(
        "the deviation on the overlapping column has visually reduced with the increase in number of points",
        "section 4",
    ),
}

#: The case study (section 6).
PAPER_CASESTUDY: dict[str, PaperValue] = {
    "flat_N": _v("21.96 N", "section 6"),
    "bucket_N": _v("19.08 N", "section 6"),
    "simulations": _v("2400 simulations", "section 6"),
    "seconds_per_simulation": _v("107.53 s", "section 6"),
    "megabytes_per_simulation": _v("9.60 MB", "section 6"),
}


def all_paper_values() -> dict[str, PaperValue]:
    """Every paper value any report quotes, keyed ``table1.<key>`` / ``casestudy.<key>``."""
    values = {f"table1.{k}": v for k, v in PAPER_TABLE1.items()}
    values.update({f"casestudy.{k}": v for k, v in PAPER_CASESTUDY.items()})
    return values
