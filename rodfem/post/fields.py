"""``fields.xdmf`` read back (:mod:`rodfem.output.readers`, which reads without VTK): the saved
fields of a run at the saved steps, in float64."""

from rodfem.output.readers import (  # noqa: F401 (their home is the reader)
    CELL_FUNCTIONS,
    FUNCTIONS,
    NODE_FUNCTIONS,
    Fields,
    FieldsError,
    read_fields,
)
