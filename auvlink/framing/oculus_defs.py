"""Field tables of the Blueprint Subsea Oculus network protocol (little-endian, byte-packed).

Source: the Oculus SDK header ``Oculus.h`` (Blueprint Subsea, 2017) as published in
apl-ocean-engineering/liboculus ``thirdparty/Oculus/Oculus.h``, and liboculus ``Constants.h``
(ports, flag bits); facts only. Offsets are 0-based from the start of the network message.
Values stay in the wire's units here (range demand m or %, gain %, pressure bar, angles deg);
:mod:`auvlink.codecs.oculus` turns bearings into rad.
"""

from __future__ import annotations

from auvlink.fields import Field, Layout

#: ``OCULUS_CHECK_ID`` of Oculus.h: the first two bytes of every message (``53 4F`` on the wire)
OCULUS_ID = 0x4F53
OCULUS_ID_BYTES = OCULUS_ID.to_bytes(2, "little")
#: ``OculusMessageType`` / status message id of Oculus.h
MSG_STATUS = 0x01
MSG_SIMPLE_FIRE = 0x15
MSG_PING_RESULT = 0x22
MSG_SIMPLE_PING_RESULT = 0x23
MSG_USER_CONFIG = 0x55
MSG_LOGS = 0x80
MSG_DUMMY = 0xFF
KNOWN_MESSAGES = frozenset({MSG_STATUS, MSG_SIMPLE_FIRE, MSG_PING_RESULT, MSG_SIMPLE_PING_RESULT,
                            MSG_USER_CONFIG, MSG_LOGS, MSG_DUMMY})
#: liboculus Constants.h: TCP data port (fire messages in, pings out) and UDP status broadcast port
DATA_PORT = 52100
STATUS_PORT = 52102
#: ``OculusSimpleFireMessage.flags`` bits (liboculus Constants.h ``FlagBits``)
FLAG_RANGE_AS_METERS = 0x01
FLAG_DATA_16BIT = 0x02
FLAG_SEND_GAIN = 0x04
FLAG_SIMPLE_RETURN = 0x08
FLAG_GAIN_ASSISTANCE = 0x10
FLAG_512_BEAMS = 0x40
#: ``OculusSimpleFireMessage2.extFlags`` bit that asks for 32-bit image data (liboculus comment in Oculus.h)
EXT_FLAG_DATA_32BIT = 0x200
#: ``DataSizeType`` of Oculus.h -> bytes per image sample
DATA_SIZE_BYTES = {0: 1, 1: 2, 2: 3, 3: 4}
BYTES_DATA_SIZE = {1: 0, 2: 1, 4: 3}
#: ``masterMode`` of the fire message: 1 = low frequency (wide aperture), 2 = high frequency (Oculus.h)
FREQ_MODE_LOW = 1
FREQ_MODE_HIGH = 2
#: bearing table resolution (Oculus.h: "bearings ... in 0.01 degree resolution")
BEARING_DEG_PER_COUNT = 0.01

HEADER = Layout("<", [
    Field("oculus_id", "H"), Field("src_device_id", "H"), Field("dst_device_id", "H"), Field("msg_id", "H"),
    Field("msg_version", "H"), Field("payload_size", "I"), Field("spare", "H"),
])
_FIRE_FIELDS = [
    Field("master_mode", "B"), Field("ping_rate", "B"), Field("network_speed", "B"), Field("gamma_correction", "B"),
    Field("flags", "B"), Field("range", "d"), Field("gain_percent", "d", unit="%"),
    Field("speed_of_sound", "d", unit="m/s"), Field("salinity", "d", unit="ppt"),
]
FIRE_V1 = Layout("<", _FIRE_FIELDS)
FIRE_V2 = Layout("<", [*_FIRE_FIELDS, Field("ext_flags", "I"), *(Field(f"reserved{k}", "I") for k in range(8))])
PING_V1 = Layout("<", [
    Field("ping_id", "I"), Field("status", "I"), Field("frequency", "d", unit="Hz"),
    Field("temperature", "d", unit="degC"), Field("pressure", "d", unit="bar"),
    Field("speed_of_sound_used", "d", unit="m/s"), Field("ping_start_time", "I"), Field("data_size", "B"),
    Field("range_resolution", "d", unit="m"), Field("n_ranges", "H"), Field("n_beams", "H"),
    Field("image_offset", "I"), Field("image_size", "I"), Field("message_size", "I"),
])
PING_V2 = Layout("<", [
    Field("ping_id", "I"), Field("status", "I"), Field("frequency", "d", unit="Hz"),
    Field("temperature", "d", unit="degC"), Field("pressure", "d", unit="bar"), Field("heading", "d", unit="deg"),
    Field("pitch", "d", unit="deg"), Field("roll", "d", unit="deg"), Field("speed_of_sound_used", "d", unit="m/s"),
    Field("ping_start_time", "d", unit="s"), Field("data_size", "B"), Field("range_resolution", "d", unit="m"),
    Field("n_ranges", "H"), Field("n_beams", "H"), *(Field(f"spare{k}", "I") for k in range(4)),
    Field("image_offset", "I"), Field("image_size", "I"), Field("message_size", "I"),
])
STATUS = Layout("<", [
    Field("device_id", "I"), Field("device_type", "H"), Field("part_number", "H"), Field("status", "I"),
    *(Field(f"firmware{k}", "I") for k in range(6)), Field("ip_addr", "4s"), Field("ip_mask", "4s"),
    Field("connected_ip_addr", "4s"), Field("mac_addr", "6s"),
    *(Field(f"temperature{k}", "d", unit="degC") for k in range(8)), Field("pressure", "d", unit="bar"),
])

#: the largest image the protocol can describe that we accept: 1024 beams (the widest M-series beam
#: forming is 512; the 1024 margin is the issue's envelope) x 4096 range lines x 4-byte samples
MAX_BEAMS = 1024
MAX_RANGES = 4096
#: fire + ping V2 fields + a 1024-entry bearing table fit in 4096 B (the capture's image offset is 2048)
MAX_IMAGE_OFFSET = 4096
MAX_PAYLOAD = MAX_IMAGE_OFFSET + MAX_BEAMS * MAX_RANGES * 4 + MAX_RANGES * 4
