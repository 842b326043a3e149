"""SpectraTac: host library for the camera-free optical tactile sensor.

Streaming and decoding run on NumPy alone; torch is imported only by training and export.
"""

__version__ = "0.1.0"

__all__ = ["__version__"]
