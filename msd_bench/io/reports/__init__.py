"""What a run shows: Table 1 as Markdown/CSV/JSON, figures, the one-page HTML report, the live view's
server.
"""
