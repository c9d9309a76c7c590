// Generated from the device layer (the register table, table 3, reasons.hpp): do not edit.
// tests/web_app_text_test.cpp fails when it drifts; RTUKIT_UPDATE_WEB_TEXT=1 with that
// test rewrites it.
export const MOTIONS = {
  "1": "static",
  "2": "forward",
  "3": "reverse",
  "4": "spin left",
  "5": "spin right",
  "6": "forward-left",
  "7": "forward-right",
  "8": "reverse-left",
  "9": "reverse-right"
};
export const ERRORS = {
  "1010": {
    "code": "1010",
    "function": "Master",
    "text": "1010 Master Error",
    "advice": "the host gets no valid answer from the controller (communication); check: the controller is powered on, the UART cable and its connectors, the baud rate (115200 unless changed) and the unit (1); a device ID other than 0x68 means another device answers on this port; when it clears, nothing restarts by itself: press the command again"
  },
  "1011": {
    "code": "1011",
    "function": "Master",
    "text": "1011 Master Error",
    "advice": "the controller's main board reports a fault; check: the controller's power and battery connection; switch the chair off and on; a code that comes back needs the dealer; when it clears, nothing restarts by itself: press the command again"
  },
  "1012": {
    "code": "1012",
    "function": "Master",
    "text": "1012 Master Error",
    "advice": "the controller's main board reports a fault; check: the controller's power and battery connection; switch the chair off and on; a code that comes back needs the dealer; when it clears, nothing restarts by itself: press the command again"
  },
  "1013": {
    "code": "1013",
    "function": "Master",
    "text": "1013 Master Error",
    "advice": "the controller's main board reports a fault; check: the controller's power and battery connection; switch the chair off and on; a code that comes back needs the dealer; when it clears, nothing restarts by itself: press the command again"
  },
  "1014": {
    "code": "1014",
    "function": "Master",
    "text": "1014 Master Error",
    "advice": "the controller's main board reports a fault; check: the controller's power and battery connection; switch the chair off and on; a code that comes back needs the dealer; when it clears, nothing restarts by itself: press the command again"
  },
  "1015": {
    "code": "1015",
    "function": "Master",
    "text": "1015 Master Error",
    "advice": "the controller's main board reports a fault; check: the controller's power and battery connection; switch the chair off and on; a code that comes back needs the dealer; when it clears, nothing restarts by itself: press the command again"
  },
  "1016": {
    "code": "1016",
    "function": "Master",
    "text": "1016 Master Error",
    "advice": "the controller's main board reports a fault; check: the controller's power and battery connection; switch the chair off and on; a code that comes back needs the dealer; when it clears, nothing restarts by itself: press the command again"
  },
  "1017": {
    "code": "1017",
    "function": "Master",
    "text": "1017 Master Error",
    "advice": "the controller's main board reports a fault; check: the controller's power and battery connection; switch the chair off and on; a code that comes back needs the dealer; when it clears, nothing restarts by itself: press the command again"
  },
  "101D": {
    "code": "101D",
    "function": "Master",
    "text": "101D Master Error",
    "advice": "the controller's main board reports a fault; check: the controller's power and battery connection; switch the chair off and on; a code that comes back needs the dealer; when it clears, nothing restarts by itself: press the command again"
  },
  "1081": {
    "code": "1081",
    "function": "Tilt",
    "text": "1081 Tilt Error",
    "advice": "a tilt actuator (whole-seat tilt, actuator 3; seat-plate tilt, actuator 6) or its drive reports a fault; check: nothing blocks the seat's tilt; the cables and connectors of actuators 3 and 6; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "1082": {
    "code": "1082",
    "function": "Tilt",
    "text": "1082 Tilt Error",
    "advice": "a tilt actuator (whole-seat tilt, actuator 3; seat-plate tilt, actuator 6) or its drive reports a fault; check: nothing blocks the seat's tilt; the cables and connectors of actuators 3 and 6; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "1083": {
    "code": "1083",
    "function": "Tilt",
    "text": "1083 Tilt Error",
    "advice": "a tilt actuator (whole-seat tilt, actuator 3; seat-plate tilt, actuator 6) or its drive reports a fault; check: nothing blocks the seat's tilt; the cables and connectors of actuators 3 and 6; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "1084": {
    "code": "1084",
    "function": "Tilt",
    "text": "1084 Tilt Error",
    "advice": "a tilt actuator (whole-seat tilt, actuator 3; seat-plate tilt, actuator 6) or its drive reports a fault; check: nothing blocks the seat's tilt; the cables and connectors of actuators 3 and 6; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "1085": {
    "code": "1085",
    "function": "Tilt",
    "text": "1085 Tilt Error",
    "advice": "a tilt actuator (whole-seat tilt, actuator 3; seat-plate tilt, actuator 6) or its drive reports a fault; check: nothing blocks the seat's tilt; the cables and connectors of actuators 3 and 6; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "1086": {
    "code": "1086",
    "function": "Tilt",
    "text": "1086 Tilt Error",
    "advice": "a tilt actuator (whole-seat tilt, actuator 3; seat-plate tilt, actuator 6) or its drive reports a fault; check: nothing blocks the seat's tilt; the cables and connectors of actuators 3 and 6; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "1087": {
    "code": "1087",
    "function": "Tilt",
    "text": "1087 Tilt Error",
    "advice": "a tilt actuator (whole-seat tilt, actuator 3; seat-plate tilt, actuator 6) or its drive reports a fault; check: nothing blocks the seat's tilt; the cables and connectors of actuators 3 and 6; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "1088": {
    "code": "1088",
    "function": "Tilt",
    "text": "1088 Tilt Error",
    "advice": "a tilt actuator (whole-seat tilt, actuator 3; seat-plate tilt, actuator 6) or its drive reports a fault; check: nothing blocks the seat's tilt; the cables and connectors of actuators 3 and 6; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "1089": {
    "code": "1089",
    "function": "Tilt",
    "text": "1089 Tilt Error",
    "advice": "a tilt actuator (whole-seat tilt, actuator 3; seat-plate tilt, actuator 6) or its drive reports a fault; check: nothing blocks the seat's tilt; the cables and connectors of actuators 3 and 6; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "108A": {
    "code": "108A",
    "function": "Tilt",
    "text": "108A Tilt Error",
    "advice": "a tilt actuator (whole-seat tilt, actuator 3; seat-plate tilt, actuator 6) or its drive reports a fault; check: nothing blocks the seat's tilt; the cables and connectors of actuators 3 and 6; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "108D": {
    "code": "108D",
    "function": "Tilt",
    "text": "108D Tilt Error",
    "advice": "a tilt actuator (whole-seat tilt, actuator 3; seat-plate tilt, actuator 6) or its drive reports a fault; check: nothing blocks the seat's tilt; the cables and connectors of actuators 3 and 6; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "1091": {
    "code": "1091",
    "function": "Legs",
    "text": "1091 Legs Error",
    "advice": "a leg-rest actuator (rotation, actuator 4; extension, actuator 5) or its drive reports a fault; check: nothing blocks the leg rest; the cables and connectors of actuators 4 and 5; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "1092": {
    "code": "1092",
    "function": "Legs",
    "text": "1092 Legs Error",
    "advice": "a leg-rest actuator (rotation, actuator 4; extension, actuator 5) or its drive reports a fault; check: nothing blocks the leg rest; the cables and connectors of actuators 4 and 5; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "1093": {
    "code": "1093",
    "function": "Legs",
    "text": "1093 Legs Error",
    "advice": "a leg-rest actuator (rotation, actuator 4; extension, actuator 5) or its drive reports a fault; check: nothing blocks the leg rest; the cables and connectors of actuators 4 and 5; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "1094": {
    "code": "1094",
    "function": "Legs",
    "text": "1094 Legs Error",
    "advice": "a leg-rest actuator (rotation, actuator 4; extension, actuator 5) or its drive reports a fault; check: nothing blocks the leg rest; the cables and connectors of actuators 4 and 5; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "1095": {
    "code": "1095",
    "function": "Legs",
    "text": "1095 Legs Error",
    "advice": "a leg-rest actuator (rotation, actuator 4; extension, actuator 5) or its drive reports a fault; check: nothing blocks the leg rest; the cables and connectors of actuators 4 and 5; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "1096": {
    "code": "1096",
    "function": "Legs",
    "text": "1096 Legs Error",
    "advice": "a leg-rest actuator (rotation, actuator 4; extension, actuator 5) or its drive reports a fault; check: nothing blocks the leg rest; the cables and connectors of actuators 4 and 5; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "1097": {
    "code": "1097",
    "function": "Legs",
    "text": "1097 Legs Error",
    "advice": "a leg-rest actuator (rotation, actuator 4; extension, actuator 5) or its drive reports a fault; check: nothing blocks the leg rest; the cables and connectors of actuators 4 and 5; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "1098": {
    "code": "1098",
    "function": "Legs",
    "text": "1098 Legs Error",
    "advice": "a leg-rest actuator (rotation, actuator 4; extension, actuator 5) or its drive reports a fault; check: nothing blocks the leg rest; the cables and connectors of actuators 4 and 5; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "1099": {
    "code": "1099",
    "function": "Legs",
    "text": "1099 Legs Error",
    "advice": "a leg-rest actuator (rotation, actuator 4; extension, actuator 5) or its drive reports a fault; check: nothing blocks the leg rest; the cables and connectors of actuators 4 and 5; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "109A": {
    "code": "109A",
    "function": "Legs",
    "text": "109A Legs Error",
    "advice": "a leg-rest actuator (rotation, actuator 4; extension, actuator 5) or its drive reports a fault; check: nothing blocks the leg rest; the cables and connectors of actuators 4 and 5; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "109B": {
    "code": "109B",
    "function": "Legs",
    "text": "109B Legs Error",
    "advice": "a leg-rest actuator (rotation, actuator 4; extension, actuator 5) or its drive reports a fault; check: nothing blocks the leg rest; the cables and connectors of actuators 4 and 5; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "10B1": {
    "code": "10B1",
    "function": "Back",
    "text": "10B1 Back Error",
    "advice": "the backrest actuator (actuator 2) or its drive reports a fault; check: nothing blocks the backrest; actuator 2's cable and connector; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "10B2": {
    "code": "10B2",
    "function": "Back",
    "text": "10B2 Back Error",
    "advice": "the backrest actuator (actuator 2) or its drive reports a fault; check: nothing blocks the backrest; actuator 2's cable and connector; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "10B3": {
    "code": "10B3",
    "function": "Back",
    "text": "10B3 Back Error",
    "advice": "the backrest actuator (actuator 2) or its drive reports a fault; check: nothing blocks the backrest; actuator 2's cable and connector; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "10B4": {
    "code": "10B4",
    "function": "Back",
    "text": "10B4 Back Error",
    "advice": "the backrest actuator (actuator 2) or its drive reports a fault; check: nothing blocks the backrest; actuator 2's cable and connector; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "10B5": {
    "code": "10B5",
    "function": "Back",
    "text": "10B5 Back Error",
    "advice": "the backrest actuator (actuator 2) or its drive reports a fault; check: nothing blocks the backrest; actuator 2's cable and connector; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "10B6": {
    "code": "10B6",
    "function": "Back",
    "text": "10B6 Back Error",
    "advice": "the backrest actuator (actuator 2) or its drive reports a fault; check: nothing blocks the backrest; actuator 2's cable and connector; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "10B7": {
    "code": "10B7",
    "function": "Back",
    "text": "10B7 Back Error",
    "advice": "the backrest actuator (actuator 2) or its drive reports a fault; check: nothing blocks the backrest; actuator 2's cable and connector; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "10B8": {
    "code": "10B8",
    "function": "Back",
    "text": "10B8 Back Error",
    "advice": "the backrest actuator (actuator 2) or its drive reports a fault; check: nothing blocks the backrest; actuator 2's cable and connector; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "10B9": {
    "code": "10B9",
    "function": "Back",
    "text": "10B9 Back Error",
    "advice": "the backrest actuator (actuator 2) or its drive reports a fault; check: nothing blocks the backrest; actuator 2's cable and connector; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "10BA": {
    "code": "10BA",
    "function": "Back",
    "text": "10BA Back Error",
    "advice": "the backrest actuator (actuator 2) or its drive reports a fault; check: nothing blocks the backrest; actuator 2's cable and connector; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "10BB": {
    "code": "10BB",
    "function": "Back",
    "text": "10BB Back Error",
    "advice": "the backrest actuator (actuator 2) or its drive reports a fault; check: nothing blocks the backrest; actuator 2's cable and connector; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "10C1": {
    "code": "10C1",
    "function": "Seat lift",
    "text": "10C1 Seat lift Error",
    "advice": "the seat-lift actuator (actuator 1) or its drive reports a fault; check: nothing blocks the seat above or below; actuator 1's cable and connector; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "10C2": {
    "code": "10C2",
    "function": "Seat lift",
    "text": "10C2 Seat lift Error",
    "advice": "the seat-lift actuator (actuator 1) or its drive reports a fault; check: nothing blocks the seat above or below; actuator 1's cable and connector; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "10C3": {
    "code": "10C3",
    "function": "Seat lift",
    "text": "10C3 Seat lift Error",
    "advice": "the seat-lift actuator (actuator 1) or its drive reports a fault; check: nothing blocks the seat above or below; actuator 1's cable and connector; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "10C4": {
    "code": "10C4",
    "function": "Seat lift",
    "text": "10C4 Seat lift Error",
    "advice": "the seat-lift actuator (actuator 1) or its drive reports a fault; check: nothing blocks the seat above or below; actuator 1's cable and connector; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "10C5": {
    "code": "10C5",
    "function": "Seat lift",
    "text": "10C5 Seat lift Error",
    "advice": "the seat-lift actuator (actuator 1) or its drive reports a fault; check: nothing blocks the seat above or below; actuator 1's cable and connector; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "10C6": {
    "code": "10C6",
    "function": "Seat lift",
    "text": "10C6 Seat lift Error",
    "advice": "the seat-lift actuator (actuator 1) or its drive reports a fault; check: nothing blocks the seat above or below; actuator 1's cable and connector; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "10C7": {
    "code": "10C7",
    "function": "Seat lift",
    "text": "10C7 Seat lift Error",
    "advice": "the seat-lift actuator (actuator 1) or its drive reports a fault; check: nothing blocks the seat above or below; actuator 1's cable and connector; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "10C8": {
    "code": "10C8",
    "function": "Seat lift",
    "text": "10C8 Seat lift Error",
    "advice": "the seat-lift actuator (actuator 1) or its drive reports a fault; check: nothing blocks the seat above or below; actuator 1's cable and connector; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "10C9": {
    "code": "10C9",
    "function": "Seat lift",
    "text": "10C9 Seat lift Error",
    "advice": "the seat-lift actuator (actuator 1) or its drive reports a fault; check: nothing blocks the seat above or below; actuator 1's cable and connector; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "10CA": {
    "code": "10CA",
    "function": "Seat lift",
    "text": "10CA Seat lift Error",
    "advice": "the seat-lift actuator (actuator 1) or its drive reports a fault; check: nothing blocks the seat above or below; actuator 1's cable and connector; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "10CB": {
    "code": "10CB",
    "function": "Seat lift",
    "text": "10CB Seat lift Error",
    "advice": "the seat-lift actuator (actuator 1) or its drive reports a fault; check: nothing blocks the seat above or below; actuator 1's cable and connector; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "10D1": {
    "code": "10D1",
    "function": "Stand",
    "text": "10D1 Stand Error",
    "advice": "the stand/sit movement (actuators 1, 2 and 4 together) reports a fault; check: nothing blocks the seat, the backrest or the leg rest; the cables and connectors of actuators 1, 2 and 4; the user's position; when it clears, nothing restarts by itself: press the command again"
  },
  "10D2": {
    "code": "10D2",
    "function": "Stand",
    "text": "10D2 Stand Error",
    "advice": "the stand/sit movement (actuators 1, 2 and 4 together) reports a fault; check: nothing blocks the seat, the backrest or the leg rest; the cables and connectors of actuators 1, 2 and 4; the user's position; when it clears, nothing restarts by itself: press the command again"
  },
  "10D3": {
    "code": "10D3",
    "function": "Stand",
    "text": "10D3 Stand Error",
    "advice": "the stand/sit movement (actuators 1, 2 and 4 together) reports a fault; check: nothing blocks the seat, the backrest or the leg rest; the cables and connectors of actuators 1, 2 and 4; the user's position; when it clears, nothing restarts by itself: press the command again"
  },
  "10D4": {
    "code": "10D4",
    "function": "Stand",
    "text": "10D4 Stand Error",
    "advice": "the stand/sit movement (actuators 1, 2 and 4 together) reports a fault; check: nothing blocks the seat, the backrest or the leg rest; the cables and connectors of actuators 1, 2 and 4; the user's position; when it clears, nothing restarts by itself: press the command again"
  },
  "10D5": {
    "code": "10D5",
    "function": "Stand",
    "text": "10D5 Stand Error",
    "advice": "the stand/sit movement (actuators 1, 2 and 4 together) reports a fault; check: nothing blocks the seat, the backrest or the leg rest; the cables and connectors of actuators 1, 2 and 4; the user's position; when it clears, nothing restarts by itself: press the command again"
  },
  "10D6": {
    "code": "10D6",
    "function": "Stand",
    "text": "10D6 Stand Error",
    "advice": "the stand/sit movement (actuators 1, 2 and 4 together) reports a fault; check: nothing blocks the seat, the backrest or the leg rest; the cables and connectors of actuators 1, 2 and 4; the user's position; when it clears, nothing restarts by itself: press the command again"
  },
  "10D7": {
    "code": "10D7",
    "function": "Stand",
    "text": "10D7 Stand Error",
    "advice": "the stand/sit movement (actuators 1, 2 and 4 together) reports a fault; check: nothing blocks the seat, the backrest or the leg rest; the cables and connectors of actuators 1, 2 and 4; the user's position; when it clears, nothing restarts by itself: press the command again"
  },
  "10D8": {
    "code": "10D8",
    "function": "Stand",
    "text": "10D8 Stand Error",
    "advice": "the stand/sit movement (actuators 1, 2 and 4 together) reports a fault; check: nothing blocks the seat, the backrest or the leg rest; the cables and connectors of actuators 1, 2 and 4; the user's position; when it clears, nothing restarts by itself: press the command again"
  },
  "10D9": {
    "code": "10D9",
    "function": "Stand",
    "text": "10D9 Stand Error",
    "advice": "the stand/sit movement (actuators 1, 2 and 4 together) reports a fault; check: nothing blocks the seat, the backrest or the leg rest; the cables and connectors of actuators 1, 2 and 4; the user's position; when it clears, nothing restarts by itself: press the command again"
  },
  "10DA": {
    "code": "10DA",
    "function": "Stand",
    "text": "10DA Stand Error",
    "advice": "the stand/sit movement (actuators 1, 2 and 4 together) reports a fault; check: nothing blocks the seat, the backrest or the leg rest; the cables and connectors of actuators 1, 2 and 4; the user's position; when it clears, nothing restarts by itself: press the command again"
  },
  "10DD": {
    "code": "10DD",
    "function": "Stand",
    "text": "10DD Stand Error",
    "advice": "the stand/sit movement (actuators 1, 2 and 4 together) reports a fault; check: nothing blocks the seat, the backrest or the leg rest; the cables and connectors of actuators 1, 2 and 4; the user's position; when it clears, nothing restarts by itself: press the command again"
  },
  "1171": {
    "code": "1171",
    "function": "Support wheels",
    "text": "1171 Support wheels Error",
    "advice": "the support (anti-tip) wheels or their drive report a fault; check: the support wheels move freely and touch nothing; their cables and connectors; when it clears, nothing restarts by itself: press the command again"
  },
  "1172": {
    "code": "1172",
    "function": "Support wheels",
    "text": "1172 Support wheels Error",
    "advice": "the support (anti-tip) wheels or their drive report a fault; check: the support wheels move freely and touch nothing; their cables and connectors; when it clears, nothing restarts by itself: press the command again"
  },
  "1173": {
    "code": "1173",
    "function": "Support wheels",
    "text": "1173 Support wheels Error",
    "advice": "the support (anti-tip) wheels or their drive report a fault; check: the support wheels move freely and touch nothing; their cables and connectors; when it clears, nothing restarts by itself: press the command again"
  },
  "1174": {
    "code": "1174",
    "function": "Support wheels",
    "text": "1174 Support wheels Error",
    "advice": "the support (anti-tip) wheels or their drive report a fault; check: the support wheels move freely and touch nothing; their cables and connectors; when it clears, nothing restarts by itself: press the command again"
  },
  "1175": {
    "code": "1175",
    "function": "Support wheels",
    "text": "1175 Support wheels Error",
    "advice": "the support (anti-tip) wheels or their drive report a fault; check: the support wheels move freely and touch nothing; their cables and connectors; when it clears, nothing restarts by itself: press the command again"
  },
  "1176": {
    "code": "1176",
    "function": "Support wheels",
    "text": "1176 Support wheels Error",
    "advice": "the support (anti-tip) wheels or their drive report a fault; check: the support wheels move freely and touch nothing; their cables and connectors; when it clears, nothing restarts by itself: press the command again"
  },
  "1177": {
    "code": "1177",
    "function": "Support wheels",
    "text": "1177 Support wheels Error",
    "advice": "the support (anti-tip) wheels or their drive report a fault; check: the support wheels move freely and touch nothing; their cables and connectors; when it clears, nothing restarts by itself: press the command again"
  },
  "1178": {
    "code": "1178",
    "function": "Support wheels",
    "text": "1178 Support wheels Error",
    "advice": "the support (anti-tip) wheels or their drive report a fault; check: the support wheels move freely and touch nothing; their cables and connectors; when it clears, nothing restarts by itself: press the command again"
  },
  "1179": {
    "code": "1179",
    "function": "Support wheels",
    "text": "1179 Support wheels Error",
    "advice": "the support (anti-tip) wheels or their drive report a fault; check: the support wheels move freely and touch nothing; their cables and connectors; when it clears, nothing restarts by itself: press the command again"
  },
  "117A": {
    "code": "117A",
    "function": "Support wheels",
    "text": "117A Support wheels Error",
    "advice": "the support (anti-tip) wheels or their drive report a fault; check: the support wheels move freely and touch nothing; their cables and connectors; when it clears, nothing restarts by itself: press the command again"
  },
  "117B": {
    "code": "117B",
    "function": "Support wheels",
    "text": "117B Support wheels Error",
    "advice": "the support (anti-tip) wheels or their drive report a fault; check: the support wheels move freely and touch nothing; their cables and connectors; when it clears, nothing restarts by itself: press the command again"
  },
  "119A": {
    "code": "119A",
    "function": "Legs",
    "text": "119A Legs Error",
    "advice": "a leg-rest actuator (rotation, actuator 4; extension, actuator 5) or its drive reports a fault; check: nothing blocks the leg rest; the cables and connectors of actuators 4 and 5; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "119B": {
    "code": "119B",
    "function": "Legs",
    "text": "119B Legs Error",
    "advice": "a leg-rest actuator (rotation, actuator 4; extension, actuator 5) or its drive reports a fault; check: nothing blocks the leg rest; the cables and connectors of actuators 4 and 5; whether the actuator states show over-current; when it clears, nothing restarts by itself: press the command again"
  },
  "1271": {
    "code": "1271",
    "function": "Chassis motor",
    "text": "1271 Chassis motor Error",
    "advice": "a drive motor or its motor driver reports a fault; check: the clutch is in drive, nothing blocks the wheels, the motor cables and connectors, the battery charge; when it clears, nothing restarts by itself: press the command again"
  },
  "1272": {
    "code": "1272",
    "function": "Chassis motor",
    "text": "1272 Chassis motor Error",
    "advice": "a drive motor or its motor driver reports a fault; check: the clutch is in drive, nothing blocks the wheels, the motor cables and connectors, the battery charge; when it clears, nothing restarts by itself: press the command again"
  },
  "1273": {
    "code": "1273",
    "function": "Chassis motor",
    "text": "1273 Chassis motor Error",
    "advice": "a drive motor or its motor driver reports a fault; check: the clutch is in drive, nothing blocks the wheels, the motor cables and connectors, the battery charge; when it clears, nothing restarts by itself: press the command again"
  },
  "1274": {
    "code": "1274",
    "function": "Chassis motor",
    "text": "1274 Chassis motor Error",
    "advice": "a drive motor or its motor driver reports a fault; check: the clutch is in drive, nothing blocks the wheels, the motor cables and connectors, the battery charge; when it clears, nothing restarts by itself: press the command again"
  },
  "1275": {
    "code": "1275",
    "function": "Chassis motor",
    "text": "1275 Chassis motor Error",
    "advice": "a drive motor or its motor driver reports a fault; check: the clutch is in drive, nothing blocks the wheels, the motor cables and connectors, the battery charge; when it clears, nothing restarts by itself: press the command again"
  },
  "1276": {
    "code": "1276",
    "function": "Chassis motor",
    "text": "1276 Chassis motor Error",
    "advice": "a drive motor or its motor driver reports a fault; check: the clutch is in drive, nothing blocks the wheels, the motor cables and connectors, the battery charge; when it clears, nothing restarts by itself: press the command again"
  },
  "1277": {
    "code": "1277",
    "function": "Chassis motor",
    "text": "1277 Chassis motor Error",
    "advice": "a drive motor or its motor driver reports a fault; check: the clutch is in drive, nothing blocks the wheels, the motor cables and connectors, the battery charge; when it clears, nothing restarts by itself: press the command again"
  },
  "1278": {
    "code": "1278",
    "function": "Chassis motor",
    "text": "1278 Chassis motor Error",
    "advice": "a drive motor or its motor driver reports a fault; check: the clutch is in drive, nothing blocks the wheels, the motor cables and connectors, the battery charge; when it clears, nothing restarts by itself: press the command again"
  },
  "1279": {
    "code": "1279",
    "function": "Chassis motor",
    "text": "1279 Chassis motor Error",
    "advice": "a drive motor or its motor driver reports a fault; check: the clutch is in drive, nothing blocks the wheels, the motor cables and connectors, the battery charge; when it clears, nothing restarts by itself: press the command again"
  },
  "127A": {
    "code": "127A",
    "function": "Chassis motor",
    "text": "127A Chassis motor Error",
    "advice": "a drive motor or its motor driver reports a fault; check: the clutch is in drive, nothing blocks the wheels, the motor cables and connectors, the battery charge; when it clears, nothing restarts by itself: press the command again"
  },
  "127B": {
    "code": "127B",
    "function": "Chassis motor",
    "text": "127B Chassis motor Error",
    "advice": "a drive motor or its motor driver reports a fault; check: the clutch is in drive, nothing blocks the wheels, the motor cables and connectors, the battery charge; when it clears, nothing restarts by itself: press the command again"
  }
};
export const REASONS = {
  "2": "no communication with the controller",
  "1": " is active",
  "3": "STOP is on: lift it on the display to use the chair again",
  "4": "stopping: wait until the chair is still",
  "5": "waiting for the controller's state",
  "15": "no standing up or raising the seat while charging",
  "6": "no driving while charging",
  "7": "no driving with the clutch in push (free-wheel) mode",
  "8": "no phone driving while the chair is not fully seated",
  "9": "the joystick on the chair is in use",
  "10": "phone drive only while the chair is static",
  "11": "another phone is driving",
  "12": "not allowed to drive yet: on the display, tap \"Allow to drive\" beside this phone's name (R-18)",
  "13": "the chair could not be set to speed level 1, as a phone drives (D-14)",
  "14": "has ended: lift the finger and press again"
};
