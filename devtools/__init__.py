"""Developer scripts, run from a checkout and never installed: `python -m devtools.same_images` (a change that
must not change any image, checked bit for bit), `python -m devtools.figures` (the manual's figures) and
`python -m devtools.docs_tables` (the manual's tables made from the code, written into its Markdown); fuzz/, the
fuzz suite's generators and contract (tests/test_fuzz.py runs them; Hypothesis is in the test extra)."""
