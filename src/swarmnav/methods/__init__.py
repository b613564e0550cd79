"""Navigation methods: one module or sub-package per family, registered by name."""
