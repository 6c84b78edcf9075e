"""The agent layer: LLM stages over the deterministic core. Today: one-shot generation."""
