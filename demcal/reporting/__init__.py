"""What a user reads: the terminal summaries, the report's headline, the figures, the live page."""
