"""The physical car's ``model.pb``: written (``drx model export --for-car``) and run as the car runs it."""
