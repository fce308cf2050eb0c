"""datagen: synthetic, annotated, reproducible datasets for robot learning."""

__version__ = "0.1.0"
