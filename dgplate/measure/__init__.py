"""Measurements of a deformed plate: fields for output, curvatures, fold angles of creases and hinges."""
