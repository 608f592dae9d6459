"""jellysim: soft, wobbly bodies as 3D mass-spring networks."""
__version__ = "0.1.0"
__all__ = ["__version__"]
