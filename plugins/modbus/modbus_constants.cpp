// Cross-check of this server's protocol constants against libmodbus's
// headers. libmodbus is used for nothing else: it never sees a request
// (3.1.6 has known overflows in its request handling) and is not linked.
#include "request.hpp"

#include <modbus.h>
#include <modbus-tcp.h>

namespace cobridge::modbus {

static_assert(static_cast<int>(ExceptionCode::kIllegalFunction) == MODBUS_EXCEPTION_ILLEGAL_FUNCTION);
static_assert(static_cast<int>(ExceptionCode::kIllegalDataAddress) == MODBUS_EXCEPTION_ILLEGAL_DATA_ADDRESS);
static_assert(static_cast<int>(ExceptionCode::kIllegalDataValue) == MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE);
static_assert(static_cast<int>(ExceptionCode::kServerDeviceFailure) == MODBUS_EXCEPTION_SLAVE_OR_SERVER_FAILURE);
static_assert(static_cast<int>(ExceptionCode::kGatewayPathUnavailable) == MODBUS_EXCEPTION_GATEWAY_PATH);
static_assert(static_cast<int>(ExceptionCode::kGatewayTargetFailed) == MODBUS_EXCEPTION_GATEWAY_TARGET);
static_assert(static_cast<int>(FunctionCode::kReadHoldingRegisters) == MODBUS_FC_READ_HOLDING_REGISTERS);
static_assert(static_cast<int>(FunctionCode::kReadInputRegisters) == MODBUS_FC_READ_INPUT_REGISTERS);
static_assert(static_cast<int>(FunctionCode::kWriteSingleRegister) == MODBUS_FC_WRITE_SINGLE_REGISTER);
static_assert(static_cast<int>(FunctionCode::kWriteMultipleRegisters) == MODBUS_FC_WRITE_MULTIPLE_REGISTERS);
static_assert(kMaxReadQuantity == MODBUS_MAX_READ_REGISTERS);
static_assert(kMaxWriteQuantity == MODBUS_MAX_WRITE_REGISTERS);
static_assert(kMaxFrameSize == MODBUS_TCP_MAX_ADU_LENGTH);

}  // namespace cobridge::modbus
