"""predgait.workflows: file-to-file pipelines behind the CLI commands."""
