"""Objects: mesh files -> checked meshes, convex collision pieces and mass; default shapes;
grasp generation."""
