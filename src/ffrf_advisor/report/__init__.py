"""Reports: console summaries, figures, HTML and PDF."""
