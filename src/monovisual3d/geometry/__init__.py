"""The geometry of objects in images: where spheres (and ellipsoids) project, as boxes and outlines."""
