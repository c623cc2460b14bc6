"""Data: validated records, readers for csv/parquet/npz/mat, condition splits and bundled datasets."""

from ..units import KNOWN_UNITS as KNOWN_UNITS
from ..units import check_units as check_units
from .builtin import BUILTINS as BUILTINS
from .builtin import load_builtin as load_builtin
from .readers import read as read
from .readers import read_mat as read_mat
from .readers import read_npz as read_npz
from .readers import read_table as read_table
from .records import Record as Record
from .records import RecordSet as RecordSet
from .records import with_travel_before as with_travel_before
from .splits import Split as Split

__all__ = [
    "BUILTINS",
    "KNOWN_UNITS",
    "Record",
    "RecordSet",
    "Split",
    "check_units",
    "load_builtin",
    "read",
    "read_mat",
    "read_npz",
    "read_table",
    "with_travel_before",
]
