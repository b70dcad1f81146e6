"""kinolab's analysis package: load results databases, compute statistics, draw, report.

Run with Debian's interpreter (it sees python3-pandas, -scipy, -matplotlib, -jinja2):
    /usr/bin/python3 -m kinolab_analysis report out/quick --out out/quick/report
"""

__all__ = ["data", "stats", "plots", "report"]
