"""Plate models: one module per energy (docs/design.md §6)."""
