"""Meshes with named cell and facet regions, distributed with shared-facet ghosts."""
