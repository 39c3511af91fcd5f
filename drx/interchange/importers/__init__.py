"""``drx model import`` of a drx package or a DeepRacer car archive (``model.pb``)."""
