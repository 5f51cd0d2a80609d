"""One router per resource: jobs, the catalogue (models, methods), health."""
