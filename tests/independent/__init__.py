"""An independent test-data generator: a second rig simulator, DAQ model and file writers, written
from the thesis digest and the file formats only, to judge odsuite on data it was not written from."""
