"""Knowing the limits of an answer: consistency with the instrument, predicted accuracy, provenance."""
