"""The agent layer: the LLM stages over the deterministic core: the staged run (plan, review,
build, refine, materials, articulation), the one-shot control and ``revise``."""
