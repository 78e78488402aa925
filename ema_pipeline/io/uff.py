"""Universal File Format: FRFs and time records (dataset 58 / 58b) in, FRFs,
time records and identified modes out.

Reading uses our own parser (:mod:`.uff_format`, which says why not pyuff's)
and unit rules (:mod:`.uff_units`); writing uses pyuff.

Reading rules
-------------
* Datasets 58 and 58b hold the functions; 164 sets the unit system of the
  datasets that follow it (up to the next 164; SI before the first); 151 is
  kept as header text. Every other dataset (15, 18, 55, 82, 2411, 2412, 2414,
  1858, ...) is skipped; :func:`read_uff` lists them and the logger
  ``ema_pipeline.io.uff`` reports them at INFO level (for ``--verbose``).
* FRF records (function type 4) are grouped into one FRF matrix by response and
  reference DOF; coherence records (type 6) are attached when every FRF has one.
* Direction sign: a DOF is (node, |direction|). A record measured in -X is
  multiplied by -1 (and again for a -X reference), so +X and -X of one node
  are ONE DOF and the values are those of the +X direction.
* When a node number is 0 and the entity name holds a DOF (``1+Z``, ``.1.Z-``),
  the DOF is taken from the name.
* Units, most specific first:

  1. the units labels of records 9 and 10 (``g/N``, ``(m/s)/N``, ``m/s^2``
     with ``N``, ``in/s^2/lbf``, ...): a label says what the numbers are, and
     the specification gives labels precedence ("If fields 5 and 6 are
     supplied, they take precedence");
  2. where a label is NONE or blank: the specific data type (8, 11, 12
     numerator; 13 or 9 denominator) with the unit exponents of the UFF table
     (the record's exponent fields for data types 0 and 1) in the unit system
     of the dataset 164 in force.

  **When a label and dataset 164 disagree, the label wins**; a warning is
  logged. When the label's quantity and the specific data type disagree, the
  label wins as well (warning logged). An unknown label is an error, never a
  silent SI.
* Uneven abscissa (spacing flag 0): the values are kept as stored. The FRFSet
  then has a non-uniform axis (:func:`ema_pipeline.data.axis_is_uniform` tells);
  identification needs equally spaced lines and must refuse it with a message
  to resample.
* Too few lines: ``min_lines`` (default 2) refuses FRFs with fewer lines;
  callers that identify pass :data:`ema_pipeline.data.MIN_FRF_LINES`.

Our own files also store the exact sample rate and record length in ID line 4
(``ema-pipeline fs=... ns=...``; the UFF header keeps the abscissa increment in
an E13.5 field only, df = 2000/16384 Hz becomes 0.12207) and the record count
(``nrec=``), so a file cut at a record boundary is seen as truncated. The
``key=value`` pairs fill ID line 4 and go on in line 5 (line 3 holds a long
configuration name), every line within 80 characters; numbers are written
exactly when short, else to 10 significant digits (:func:`id_number`).

The code: :mod:`.uff_read` (reading) and :mod:`.uff_write` (writing); every
name is imported from here.
"""

from ema_pipeline.io.uff_read import (
    UFF_SUFFIXES,
    check_record_count,
    ordinate_unit,
    read_frf_uff,
    read_time_uff,
    read_uff,
    response_dof,
)
from ema_pipeline.io.uff_write import (
    ID_LINE_CHARS,
    id_number,
    write_frf_uff,
    write_modes_uff,
    write_time_uff,
)

__all__ = ["ID_LINE_CHARS", "UFF_SUFFIXES", "check_record_count", "id_number", "ordinate_unit",
           "read_frf_uff", "read_time_uff", "read_uff", "response_dof", "write_frf_uff",
           "write_modes_uff", "write_time_uff"]
