"""jinja2 templates of the generated C, CasADi loader and Markdown report (shipped as package data)."""
