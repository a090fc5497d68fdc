"""What the apps do, without argparse: render and demo a spec, analyze points, as-worn
maps, batch grids and the inspector's model."""
