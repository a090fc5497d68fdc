"""Procedural inputs with known properties: sample prescriptions, eyes and lens specs."""
