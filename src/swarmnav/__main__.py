from swarmnav.cli import main
import sys
sys.exit(main())
