"""Thin command-line and GUI front ends of eyelab."""
