"""Parameter and vehicle files, and the loader both processes read them with."""
