"""CAM: tools, collision, roughing, finishing, verification, motion and the CLI."""
