"""``python -m physics.stability``: the command of the stability study (physics.studies.stability_study).

Kept at this path because the command is documented and scripted under this name; the study itself lives
in the studies wing. Nothing in the library imports this module.
"""

import sys

from physics.studies.stability_study import main

if __name__ == "__main__":
    sys.exit(main())
