"""The digital twin: synthetic logs that follow the paper's protocols (every file it writes is labelled synthetic)."""
