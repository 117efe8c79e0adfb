"""Sim-to-real gap diagnosis: where the gap lies, which unmodelled effect causes it, how far it shrinks."""
