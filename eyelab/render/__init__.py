"""Everything that touches VTK / PyVista lives here (and only here)."""
