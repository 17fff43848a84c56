"""State estimation: attitude and position filters behind one interface."""
