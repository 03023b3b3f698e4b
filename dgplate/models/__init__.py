"""Plate models: one module per energy (DESIGN.md §6)."""
