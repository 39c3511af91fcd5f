"""Recipes: a whole model's settings built for a track, each choice with its reason (``--recipe``)."""
