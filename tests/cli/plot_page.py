#!/usr/bin/env python3
"""Checks a page written by 'saulctl plot -o run.html' without a browser (plot_browser.sh runs it in one).

  plot_page.py PAGE          exit 0 when the page is self-contained: every script inline (no src), no <link>,
                             <img>, <iframe>, <object> or <embed>, the dygraphs library and the page's data there
  plot_page.py PAGE --data   prints "N panels T0..T1 DATE TOD": the panels in the data, the time span of their
                             rows, the date and time of day (seconds since midnight UTC) of time 0
"""
import json
import sys
from html.parser import HTMLParser


class Page(HTMLParser):
    def __init__(self):
        super().__init__()
        self.problems, self.scripts, self.data, self._in_data = [], [], None, False

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "script":
            if "src" in a:
                self.problems.append("script with src=%s" % a["src"])
            self._in_data = a.get("id") == "plot-data"
            self.scripts.append("")
        elif tag in ("link", "img", "iframe", "object", "embed"):
            self.problems.append("<%s> element" % tag)

    def handle_endtag(self, tag):
        if tag == "script":
            self._in_data = False

    def handle_data(self, data):
        if self.scripts and self.lasttag == "script":
            self.scripts[-1] += data
            if self._in_data:
                self.data = (self.data or "") + data


def main():
    page = Page()
    page.feed(open(sys.argv[1], encoding="utf-8").read())
    if page.data is None:
        page.problems.append("no plot-data script")
    if not any("Dygraph" in s and len(s) > 50000 for s in page.scripts):
        page.problems.append("no inline dygraphs library")
    if page.problems:
        print("; ".join(page.problems), file=sys.stderr)
        return 1
    if "--data" in sys.argv:
        d = json.loads(page.data)
        ts = [row[0] for p in d["panels"] for row in p["rows"]]
        print("%d panels %g..%g %s %s" % (len(d["panels"]), min(ts), max(ts), d["start_date"],
                                          round(d["start_tod_s"], 6)))
    return 0


sys.exit(main())
