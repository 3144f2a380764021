"""Old name of raytrace.tools.figures, kept so that `python -m raytrace.figures` still works."""
from .tools.figures import main

if __name__ == "__main__":
    main()
