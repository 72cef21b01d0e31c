"""`mpsynth design`: the interactive designer, a local web page that re-synthesizes as the task changes.

`session.Session` holds the task and makes every decision (`synth_view`: the synthesis, `background`:
the design search behind, cancellable; `document`: the task file's numbers, written back in place;
`scene`: what is drawn); `server` serves `page` and the session's JSON API (the optional extra
``mpsynth[design]``: starlette and uvicorn, imported only there).
"""
