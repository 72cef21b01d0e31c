"""Tools on a written linkage: render, viewer, collision check, simulation, batch jobs."""
