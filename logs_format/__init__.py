"""logs_format: the auvlink mission log (MCAP): record raw frames, read them back, replay, inspect.

* :class:`MissionLogWriter` - a raw-frame listener for drivers; one channel per device.
* :class:`MissionLogReader` - streaming time-ordered merge of channels, robust to truncation and damage;
  :class:`LossReport` says what was lost.
* :func:`read_messages` - the messages of a log in log-time order, without a reader object.
* :class:`Replay`, :func:`replay_samples`, :func:`replay_frames` - raw frames back through the live framers and
  codecs; :func:`paced` - at a given multiple of real time.
* :class:`DecoderFactory` - for ``mcap``'s ``make_reader(f, decoder_factories=[DecoderFactory()])``:
  ``iter_decoded_messages`` yields auvlink records for every raw channel.
* :func:`log_info`, :func:`export_log`, :func:`import_can_log`, :func:`import_serial_capture`.

The container and naming rules are in :mod:`logs_format.profile`; errors are :class:`LogError`.
"""

from logs_format.chunks import ChannelInfo, LogMessage
from logs_format.decoder import DecoderFactory
from logs_format.export import ExportResult, export_log
from logs_format.importers import ImportResult, import_can_log, import_serial_capture, is_can_log
from logs_format.info import format_info, log_info
from logs_format.loss import LossReport, LostSpan
from logs_format.profile import LogError
from logs_format.reader import MissionLogReader, read_messages
from logs_format.replay import Replay, paced, replay_frames, replay_samples
from logs_format.writer import MissionLogWriter

__all__ = [
    "ChannelInfo",
    "DecoderFactory",
    "ExportResult",
    "ImportResult",
    "LogError",
    "LogMessage",
    "LossReport",
    "LostSpan",
    "MissionLogReader",
    "MissionLogWriter",
    "Replay",
    "export_log",
    "format_info",
    "import_can_log",
    "import_serial_capture",
    "is_can_log",
    "log_info",
    "paced",
    "read_messages",
    "replay_frames",
    "replay_samples",
]
