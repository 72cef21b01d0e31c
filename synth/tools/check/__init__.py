"""`mpsynth check`: an independent check of a written output directory (verify) and the continuation of
its loops from the written files alone (continuation)."""
