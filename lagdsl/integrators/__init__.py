"""The bundled integrators: C sources (package data, pasted into generated files) and the
NumPy backend's fixed-step methods."""
