"""What a run records and writes: the table of history columns (``columns``, importable without
dolfinx), the recorder (``history``), the files of a run directory (``files``), the directory
itself (``directories``) and the progress bar."""
